#include "fs_xyctrl.h"
#include "fs_math.h"
#include "fs_vsd.h"

FS_COLD fs_status fs_xyctrl_init(fs_xyctrl *x, const fs_xyctrl_config *cfg)
{
    fs_status ret;
    if (!x || !cfg) { ret = FS_ERR_NULL; }
    else {
        const fs_xyctrl_config *c = cfg;
        if (!fs_pos(c->Ts)) { ret = FS_ERR_TS; }
        else if (!fs_nonneg(c->R_s)) { ret = FS_ERR_RS; }
        else if (!fs_pos(c->L_d3)) { ret = FS_ERR_LD; }
        else if (!fs_pos(c->L_q3)) { ret = FS_ERR_LQ; }
        else if (!fs_nonneg(c->psi_f3)) { ret = FS_ERR_PSI_F; }
        else if ((c->delay != 0.0f) && (c->delay != 1.0f)) { ret = FS_ERR_PARAM; }
        else if (!((c->u_max_frac > 0.0f) && (c->u_max_frac <= 0.5f))) { ret = FS_ERR_PARAM; }
        /* the loop's delay (1.5 periods with the computation delay) keeps the
         * first-order design within alpha Ts <= 0.25 (phase margin above 50 deg) */
        else if (!fs_pos(c->bandwidth) || !((c->bandwidth * c->Ts) <= 0.25f)) { ret = FS_ERR_BANDWIDTH; }
        else {
            x->cfg = *cfg;
            fs_status st = fs_pi_design_init(&x->pi_d3, c->Ts, c->L_d3, c->R_s, c->bandwidth, 0.0f);
            if (st == FS_OK) { st = fs_pi_design_init(&x->pi_q3, c->Ts, c->L_q3, c->R_s, c->bandwidth, 0.0f); }
            if (st != FS_OK) { ret = st; }
            else {
                fs_xyctrl_reset(x);
                ret = FS_OK;
            }
        }
    }
    return ret;
}

void fs_xyctrl_reset(fs_xyctrl *x)
{
    fs_pi_reset(&x->pi_d3);
    fs_pi_reset(&x->pi_q3);
    x->i3.d = 0.0f;
    x->i3.q = 0.0f;
    x->u_xy.alpha = 0.0f;
    x->u_xy.beta = 0.0f;
}

fs_ab fs_xyctrl_step(fs_xyctrl *x, const float i_ph[5], float theta_e, float w_e, float u_dc)
{
    const fs_xyctrl_config *c = &x->cfg;
    const fs_vsd5 v = fs_vsd5_forward(i_ph);
    const float th3 = 3.0f * theta_e;
    const float w3 = 3.0f * w_e;
    const fs_dq i3 = fs_park(v.xy, fs_cosf(th3), fs_sinf(th3));
    x->i3 = i3;
    /* the d3-q3 model's coupling and EMF fed forward */
    const fs_dq ff = {-w3 * c->L_q3 * i3.q, w3 * ((c->L_d3 * i3.d) + c->psi_f3)};
    fs_dq u = {fs_pi_output(&x->pi_d3, 0.0f, i3.d) + ff.d, fs_pi_output(&x->pi_q3, 0.0f, i3.q) + ff.q};
    const float lim = c->u_max_frac * u_dc;
    const float m = sqrtf((u.d * u.d) + (u.q * u.q));
    fs_dq u_real = u;
    if (m > lim) {
        float s = 0.0f;
        if (lim > 0.0f) { s = lim / m; }
        u_real.d *= s;
        u_real.q *= s;
    }
    fs_pi_update(&x->pi_d3, 0.0f, i3.d, u.d - ff.d, u_real.d - ff.d);
    fs_pi_update(&x->pi_q3, 0.0f, i3.q, u.q - ff.q, u_real.q - ff.q);
    /* acting from the next update for a period: turned to its middle */
    const float th_u = th3 + (w3 * c->Ts * (c->delay + 0.5f));
    x->u_xy = fs_inv_park(u_real, fs_cosf(th_u), fs_sinf(th_u));
    return x->u_xy;
}

void fs_xyctrl_duties(fs_ab u_xy, float u_dc, float duty[5])
{
    const fs_vsd5 p = {{0.0f, 0.0f}, {u_xy.alpha, u_xy.beta}, 0.0f};
    float u[5];
    fs_vsd5_inverse(&p, u);
    float k = 0.0f;
    if (u_dc > 0.0f) { k = 1.0f / u_dc; }
    for (int n = 0; n < 5; ++n) { duty[n] = fs_clamp01(duty[n] + (u[n] * k)); }
}
