#include "fs_svpwm.h"
#include "fs_math.h"

#include <stddef.h>

bool fs_svpwm(fs_ab u_ref, float u_dc, float duty[3], fs_ab *u_real)
{
    bool ret;
    /* all three finite: x - x is 0 for a finite x, NaN for an infinity or a
     * NaN (one test where three isfinite cost four instructions each) */
    const float inf_nan = (u_dc - u_dc) + (u_ref.alpha - u_ref.alpha) + (u_ref.beta - u_ref.beta);
    if (!(u_dc > 0.0f) || (inf_nan != 0.0f)) {
        duty[0] = 0.5f;
        duty[1] = 0.5f;
        duty[2] = 0.5f;
        if (u_real != NULL) { u_real->alpha = 0.0f; u_real->beta = 0.0f; }
        ret = (u_ref.alpha != 0.0f) || (u_ref.beta != 0.0f);
    }
    else {
        /* Work in units of u_dc, with a reference first brought inside the circle
         * of radius 2/3 u_dc (beyond it, everything is over-modulation anyway):
         * nothing below can overflow, whatever the finite inputs. */
        float pre = 1.0f;
        /* finite from here: the larger and smaller need no NaN rule */
        const float a_a = fabsf(u_ref.alpha);
        const float a_b = fabsf(u_ref.beta);
        float mag = (a_a > a_b) ? a_a : a_b;
        if (mag > u_dc) { pre = u_dc / mag; }
        fs_ab x = {u_ref.alpha * pre / u_dc, u_ref.beta * pre / u_dc};
        float v[3];
        fs_inv_clarke(x, v);
        float v_max = (v[0] > v[1]) ? v[0] : v[1];
        float v_min = (v[0] > v[1]) ? v[1] : v[0];
        if (v[2] > v_max) { v_max = v[2]; }
        if (v[2] < v_min) { v_min = v[2]; }
        float span = v_max - v_min;
        float scale = 1.0f;
        bool over = pre < 1.0f;
        /* The pole voltages can span at most u_dc: scaling the whole vector keeps
         * its phase and puts it on the hexagon (minimum phase error). */
        if (span > 1.0f) {
            scale = 1.0f / span;
            over = true;
        }
        float offset = -0.5f * (v_max + v_min) * scale;  /* min-max injection */
        for (int k = 0; k < 3; ++k) {
            duty[k] = fs_clamp01(0.5f + (v[k] * scale) + offset);
        }
        if (u_real != NULL) {
            u_real->alpha = x.alpha * scale * u_dc;
            u_real->beta = x.beta * scale * u_dc;
        }
        ret = over;
    }
    return ret;
}

fs_ab fs_svpwm_voltage(const float duty[3], float u_dc)
{
    return fs_clarke(duty[0] * u_dc, duty[1] * u_dc, duty[2] * u_dc);
}
