#include "fs_pwm5.h"
#include "fs_math.h"

#include <stddef.h>
#include "fs_vsd.h"

/* Linear limit in units of u_dc: 1 / (2 cos(pi/10)). With xy = 0 the phase
 * references are |u| cos(theta - k g); their span is largest, 2 cos(pi/10) |u|,
 * at theta = 18 + 36 n degrees, and the legs can span at most u_dc. */
static const float lin_limit = 0.525731112f;

bool fs_pwm5(fs_ab u_ref, float u_dc, float duty[5], fs_ab *u_real)
{
    bool ret;
    if (!(u_dc > 0.0f) || !isfinite(u_dc) || !isfinite(u_ref.alpha) || !isfinite(u_ref.beta)) {
        for (int k = 0; k < 5; ++k) { duty[k] = 0.5f; }
        if (u_real != NULL) { u_real->alpha = 0.0f; u_real->beta = 0.0f; }
        ret = true;
    }
    else {
        /* Work in units of u_dc, with a reference first brought within u_dc per
         * component (beyond the limit anyway): nothing below can overflow. */
        float pre = 1.0f;
        float big = fs_maxf(fabsf(u_ref.alpha), fabsf(u_ref.beta));
        if (big > u_dc) { pre = u_dc / big; }
        fs_vsd5 v = {{u_ref.alpha * pre / u_dc, u_ref.beta * pre / u_dc}, {0.0f, 0.0f}, 0.0f};
        float mag = sqrtf((v.ab.alpha * v.ab.alpha) + (v.ab.beta * v.ab.beta));
        bool over = pre < 1.0f;
        if (mag > lin_limit) {  /* onto the limit circle, same phase */
            float s = lin_limit / mag;
            v.ab.alpha *= s;
            v.ab.beta *= s;
            over = true;
        }
        float ph[5];
        fs_vsd5_inverse(&v, ph);  /* phase references, x-y and zero sequence nil */
        float v_max = ph[0];
        float v_min = ph[0];
        for (int k = 1; k < 5; ++k) {
            v_max = fs_maxf(v_max, ph[k]);
            v_min = fs_minf(v_min, ph[k]);
        }
        /* Min-max injection: equal zero-vector time at both ends of the period. */
        float offset = 0.5f - (0.5f * (v_max + v_min));
        for (int k = 0; k < 5; ++k) { duty[k] = fs_clamp01(ph[k] + offset); }
        if (u_real != NULL) { *u_real = fs_pwm5_voltage(duty, u_dc); }
        ret = over;
    }
    return ret;
}

fs_ab fs_pwm5_voltage(const float duty[5], float u_dc)
{
    /* Star point: phase voltage = pole voltage minus the mean of the poles. */
    float mean = 0.2f * (duty[0] + duty[1] + duty[2] + duty[3] + duty[4]);
    float u[5];
    for (int k = 0; k < 5; ++k) { u[k] = (duty[k] - mean) * u_dc; }
    return fs_vsd5_forward(u).ab;
}
