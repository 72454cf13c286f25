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
 * the configuration field at fault (fs_status_str gives the message). Every
 * init refuses a non-finite field: NaN, an infinity, or a double beyond the
 * float range (1e39), which arrives as an infinity. */
typedef enum {
    FS_OK = 0,
    FS_ERR_NULL = 1,            /* a null pointer was passed */
    FS_ERR_TS = 2,              /* sampling period must be finite and > 0 (carrier period >= it) */
    FS_ERR_RS = 3,              /* stator resistance must be finite and >= 0 */
    FS_ERR_LD = 4,              /* d-axis inductance must be finite and > 0 */
    FS_ERR_LQ = 5,              /* q-axis inductance must be finite and > 0 (MTPA: >= L_d) */
    FS_ERR_PSI_F = 6,           /* magnet flux must be finite and >= 0 */
    FS_ERR_POLE_PAIRS = 7,      /* pole pairs must be >= 1 */
    FS_ERR_J = 8,               /* inertia must be finite and > 0 */
    FS_ERR_BANDWIDTH = 9,       /* a bandwidth must be finite, > 0 and within its limit for Ts */
    FS_ERR_LIMIT = 10,          /* a limit must be finite and > 0 (and max > min) */
    FS_ERR_I_MAX = 11,          /* a current limit or amplitude must be finite and > 0 */
    FS_ERR_MODE = 12,           /* unknown mode or angle source */
    FS_ERR_SMO_GAIN = 13,       /* SMO gain not finite or not above the Lyapunov bound, eq. (18) */
    FS_ERR_PARAM = 14,          /* another parameter is out of range or not finite */
    FS_ERR_SALIENCY = 15,       /* injection needs a salient machine, L_d != L_q */
    FS_ERR_ABOVE_I_MAX = 16,    /* a current setting above the current limit i_max */
    FS_ERR__COUNT = 17
} fs_status;

const char *fs_status_str(fs_status status);

/* The most phases a drive has: three, or five (yu2022). */
enum { FS_PHASES_MAX = 5 };

#endif /* FS_TYPES_H */
