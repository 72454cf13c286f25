#include "fs_types.h"

const char *fs_status_str(fs_status status)
{
    switch (status) {
    case FS_OK: return "ok";
    case FS_ERR_NULL: return "a required pointer is null";
    case FS_ERR_TS: return "sampling period must be > 0";
    case FS_ERR_RS: return "stator resistance must be >= 0";
    case FS_ERR_LD: return "d-axis inductance must be > 0";
    case FS_ERR_LQ: return "q-axis inductance must be > 0";
    case FS_ERR_PSI_F: return "magnet flux linkage must be >= 0";
    case FS_ERR_POLE_PAIRS: return "pole pairs must be >= 1";
    case FS_ERR_J: return "inertia must be > 0";
    case FS_ERR_BANDWIDTH: return "bandwidth must be > 0 and below the Nyquist limit pi/Ts";
    case FS_ERR_LIMIT: return "limit must be > 0";
    case FS_ERR_I_MAX: return "current limit must be > 0";
    case FS_ERR_MODE: return "unknown mode or angle source";
    case FS_ERR_SMO_GAIN: return "SMO gain k is below the Lyapunov bound of eq. (18)";
    case FS_ERR_PARAM: return "parameter out of range";
    case FS_ERR_SALIENCY: return "injection needs a salient machine (L_d != L_q)";
    default: return "unknown status";
    }
}
