#include "fs_types.h"

const char *fs_status_str(fs_status status)
{
    switch (status) {
    case FS_OK: return "ok";
    case FS_ERR_NULL: return "a required pointer is null";
    case FS_ERR_TS: return "sampling period must be finite and > 0 (T_pwm >= Ts)";
    case FS_ERR_RS: return "stator resistance must be finite and >= 0";
    case FS_ERR_LD: return "d-axis inductance must be finite and > 0";
    case FS_ERR_LQ: return "q-axis inductance must be finite and > 0 (for MTPA, >= L_d)";
    case FS_ERR_PSI_F: return "magnet flux linkage must be finite and >= 0";
    case FS_ERR_POLE_PAIRS: return "pole pairs must be >= 1";
    case FS_ERR_J: return "inertia must be finite and > 0";
    case FS_ERR_BANDWIDTH: return "bandwidth must be finite, > 0 and below its limit for the sampling period";
    case FS_ERR_LIMIT: return "limit must be finite and > 0 (a maximum above its minimum, a margin >= 1)";
    case FS_ERR_I_MAX: return "current limit or amplitude must be finite and > 0";
    case FS_ERR_MODE: return "unknown mode or angle source";
    case FS_ERR_SMO_GAIN: return "SMO gain k must be finite and above the Lyapunov bound of eq. (18)";
    case FS_ERR_PARAM: return "parameter out of range or not finite";
    case FS_ERR_SALIENCY: return "injection needs a salient machine (L_d != L_q)";
    case FS_ERR_ABOVE_I_MAX: return "current above the current limit i_max (the injected carrier's peak: above half of it)";
    default: return "unknown status";
    }
}
