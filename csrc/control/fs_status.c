#include "fs_types.h"

const char *fs_status_str(fs_status status)
{
    const char *text;
    switch (status) {
    case FS_OK: text = "ok"; break;
    case FS_ERR_NULL: text = "a required pointer is null"; break;
    case FS_ERR_TS: text = "sampling period must be finite and > 0 (T_pwm >= Ts)"; break;
    case FS_ERR_RS: text = "stator resistance must be finite and >= 0"; break;
    case FS_ERR_LD: text = "d-axis inductance must be finite and > 0"; break;
    case FS_ERR_LQ: text = "q-axis inductance must be finite and > 0 (for MTPA, >= L_d)"; break;
    case FS_ERR_PSI_F: text = "magnet flux linkage must be finite and >= 0"; break;
    case FS_ERR_POLE_PAIRS: text = "pole pairs must be >= 1"; break;
    case FS_ERR_J: text = "inertia must be finite and > 0"; break;
    case FS_ERR_BANDWIDTH: text = "bandwidth must be finite, > 0 and below its limit for the sampling period"; break;
    case FS_ERR_LIMIT: text = "limit must be finite and > 0 (a maximum above its minimum, a margin >= 1)"; break;
    case FS_ERR_I_MAX: text = "current limit or amplitude must be finite and > 0"; break;
    case FS_ERR_MODE: text = "unknown mode or angle source"; break;
    case FS_ERR_SMO_GAIN: text = "SMO gain k must be finite and above the Lyapunov bound of eq. (18)"; break;
    case FS_ERR_PARAM: text = "parameter out of range or not finite"; break;
    case FS_ERR_SALIENCY: text = "injection needs a salient machine (L_d != L_q)"; break;
    case FS_ERR_ABOVE_I_MAX: text = "current above the current limit i_max (the injected carrier's peak: above half of it)"; break;
    default: text = "unknown status"; break;
    }
    return text;
}
