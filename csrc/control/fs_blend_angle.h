/* eq. (27) on the circle (fs_blend_angle, fs_blend.h), inline for the
 * drive's step, which takes it twice: in the blend's step and for the
 * loops' angle (fs_drive.c). As a call it cost its frame and two
 * branches around its own inline wraps, about 17 instructions a call on
 * a Cortex-M4F (bench/pil.py). Internal: not part of the cdef
 * (src/fullspeed/_build.py reads the public headers). */
#ifndef FS_BLEND_ANGLE_H
#define FS_BLEND_ANGLE_H

#include "fs_math.h"

static inline float fs_blend_angle_inline(float theta_smo, float theta_hfi, float g)
{
    float theta;
    if (g <= 0.0f) {
        theta = theta_hfi;
    } else if (g >= 1.0f) {
        theta = theta_smo;
    } else {   /* eq. (27) along the shorter arc, so that it does not break at +-pi */
        theta = theta_hfi + (g * fs_wrap_pi(theta_smo - theta_hfi));
    }
    return fs_wrap_pi(theta);
}

#endif /* FS_BLEND_ANGLE_H */
