#include "fs_svpwm.h"
#include "fs_math.h"

bool fs_svpwm(fs_ab u_ref, float u_dc, float duty[3], fs_ab *u_real)
{
    float v[3];
    fs_inv_clarke(u_ref, v);
    float v_max = fmaxf(v[0], fmaxf(v[1], v[2]));
    float v_min = fminf(v[0], fminf(v[1], v[2]));
    float span = v_max - v_min;
    float scale = 1.0f;
    bool over = false;
    if (u_dc <= 0.0f) {
        duty[0] = duty[1] = duty[2] = 0.5f;
        if (u_real) { u_real->alpha = 0.0f; u_real->beta = 0.0f; }
        return span > 0.0f;
    }
    /* The pole voltages can span at most u_dc: scaling the whole vector keeps
     * its phase and puts it on the hexagon (minimum phase error). */
    if (span > u_dc) {
        scale = u_dc / span;
        over = true;
    }
    float offset = -0.5f * (v_max + v_min) * scale;  /* min-max injection */
    float inv_dc = 1.0f / u_dc;
    for (int k = 0; k < 3; ++k) {
        duty[k] = fs_clampf(0.5f + (v[k] * scale + offset) * inv_dc, 0.0f, 1.0f);
    }
    if (u_real) {
        u_real->alpha = u_ref.alpha * scale;
        u_real->beta = u_ref.beta * scale;
    }
    return over;
}

fs_ab fs_svpwm_voltage(const float duty[3], float u_dc)
{
    return fs_clarke(duty[0] * u_dc, duty[1] * u_dc, duty[2] * u_dc);
}
