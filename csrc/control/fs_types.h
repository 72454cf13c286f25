/* fullspeed control library: common types and status codes.
 *
 * Everything in csrc/control is float32, allocation-free and global-free, and
 * includes only <math.h>, <stdint.h>, <stdbool.h> and <stddef.h>.
 *
 * Public headers in this directory are also read by the Python binding
 * (cffi cdef): keep preprocessor lines to include guards and #includes, and
 * put constants in enums and inline helpers in fs_math.h.
 */
#ifndef FS_TYPES_H
#define FS_TYPES_H

#include <stdbool.h>
#include <stdint.h>

/* Status returned by every fs_<thing>_init. FS_OK is zero; each error names
 * the configuration field at fault (fs_status_str gives the message). */
typedef enum {
    FS_OK = 0,
    FS_ERR_NULL = 1,            /* a null pointer was passed */
    FS_ERR_TS = 2,              /* sampling period must be > 0 */
    FS_ERR_RS = 3,              /* stator resistance must be >= 0 */
    FS_ERR_LD = 4,              /* d-axis inductance must be > 0 */
    FS_ERR_LQ = 5,              /* q-axis inductance must be > 0 */
    FS_ERR_PSI_F = 6,           /* magnet flux must be >= 0 */
    FS_ERR_POLE_PAIRS = 7,      /* pole pairs must be >= 1 */
    FS_ERR_J = 8,               /* inertia must be > 0 */
    FS_ERR_BANDWIDTH = 9,       /* a bandwidth must be > 0 and below the Nyquist limit */
    FS_ERR_LIMIT = 10,          /* a limit must be > 0 (and max >= min) */
    FS_ERR_I_MAX = 11,          /* current limit must be > 0 */
    FS_ERR_MODE = 12,           /* unknown mode or angle source */
    FS_ERR_SMO_GAIN = 13,       /* SMO gain below the Lyapunov bound, eq. (18) */
    FS_ERR_PARAM = 14,          /* another parameter is out of range */
    FS_ERR_SALIENCY = 15,       /* injection needs a salient machine, L_d != L_q */
    FS_ERR__COUNT = 16
} fs_status;

const char *fs_status_str(fs_status status);

/* The most phases a drive has: three, or five (yu2022). */
enum { FS_PHASES_MAX = 5 };

#endif /* FS_TYPES_H */
