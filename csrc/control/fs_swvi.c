#include "fs_swvi.h"
#include "fs_math.h"

FS_COLD fs_status fs_swvi_init(fs_swvi *s, const fs_swvi_config *cfg)
{
    fs_status ret;
    if (!s || !cfg) { ret = FS_ERR_NULL; }
    else {
        const fs_swvi_config *c = cfg;
        if (!fs_pos(c->Ts)) { ret = FS_ERR_TS; }
        else if ((c->delay != 0) && (c->delay != 1)) { ret = FS_ERR_PARAM; }
        else if (!fs_pos(c->u_h)) { ret = FS_ERR_PARAM; }
        else if ((c->sequence != (int)FS_SWVI_CONVENTIONAL) && (c->sequence != (int)FS_SWVI_OPTIMIZED)) { ret = FS_ERR_PARAM; }
        else if (!fs_pos(c->L_d)) { ret = FS_ERR_LD; }
        else if (!fs_pos(c->L_q)) { ret = FS_ERR_LQ; }
        else if (!(fabsf(c->L_q - c->L_d) > (0.01f * 0.5f * (c->L_d + c->L_q)))) { ret = FS_ERR_SALIENCY; }
        else if (!fs_nonneg(c->w_max)) { ret = FS_ERR_LIMIT; }
        else if (fs_xcomp_check(&c->xcomp) != FS_OK) { ret = FS_ERR_PARAM; }
        else {
            fs_pll_config pc = {c->Ts, c->bandwidth, c->w_max};
            fs_status st = fs_pll_init(&s->pll, &pc);
            if (st != FS_OK) { ret = st; }
            else {
                s->cfg = *c;
                /* eq. (7) with T_h = 4 Ts */
                s->k_norm = c->L_d * c->L_q / (c->Ts * c->u_h * (c->L_q - c->L_d));
                if (!fs_fin(s->k_norm)) { ret = FS_ERR_PARAM; }   /* Ts u_h too small for a float */
                else {
                    fs_swvi_reset(s, 0.0f, 0.0f);
                    ret = FS_OK;
                }
            }
        }
    }
    return ret;
}

void fs_swvi_reset(fs_swvi *s, float theta, float w)
{
    fs_pll_reset(&s->pll, theta, w);
    s->k = 0;
    for (int n = 0; n < 4; ++n) {
        s->i_ab[n].alpha = 0.0f;
        s->i_ab[n].beta = 0.0f;
        s->i_dq[n].d = 0.0f;
        s->i_dq[n].q = 0.0f;
        s->theta_u[n] = s->pll.theta;
    }
    s->ff_fresh = false;
    s->i_f.alpha = 0.0f;
    s->i_f.beta = 0.0f;
    s->i_h.d = 0.0f;
    s->i_h.q = 0.0f;
    s->eps = 0.0f;
    s->delta = 0.0f;
    s->theta = s->pll.theta;
    s->w = w;
    s->u.alpha = 0.0f;
    s->u.beta = 0.0f;
}

/* The mean of two angles a step apart. */
static float mid_angle(float a, float b) { return fs_wrap_pi(a + (0.5f * fs_wrap_pi(b - a))); }

float fs_swvi_step(fs_swvi *s, fs_ab i)
{
    const fs_swvi_config *c = &s->cfg;
    const int n = (int)(s->k & 3);
    const float th_prev = s->pll.theta;   /* theta_{k-1} */
    s->i_ab[n] = i;
    if (c->sequence == (int)FS_SWVI_CONVENTIONAL) { s->i_dq[n] = fs_park(i, fs_cosf(th_prev), fs_sinf(th_prev)); }

    /* eq. (8) at the zero crossings (even samples); the first window with
     * the carrier in both its intervals ends at sample 4 */
    s->ff_fresh = (n & 1) == 0;
    if (s->ff_fresh) {
        s->i_f = i;
        if (s->k >= 4) {
            const int n1 = (n + 3) & 3;                     /* k - 1 (the peak), k - 2 */
            const int n2 = (n + 2) & 3;
            fs_dq h;
            if (c->sequence == (int)FS_SWVI_OPTIMIZED) {
                fs_ab hab = {s->i_ab[n1].alpha - (0.5f * (s->i_ab[n2].alpha + i.alpha)),
                             s->i_ab[n1].beta - (0.5f * (s->i_ab[n2].beta + i.beta))};
                const float phi = mid_angle(s->theta_u[n2], s->theta_u[n1]);   /* eq. (16) */
                h = fs_park(hab, fs_cosf(phi), fs_sinf(phi));
            } else {
                h.d = s->i_dq[n1].d - (0.5f * (s->i_dq[n2].d + s->i_dq[n].d));
                h.q = s->i_dq[n1].q - (0.5f * (s->i_dq[n2].q + s->i_dq[n].q));
            }
            /* the half before the peak: + when the window starts at phase 0 */
            const float sign = (n2 == 0) ? 1.0f : -1.0f;
            s->i_h.d = sign * h.d;
            s->i_h.q = sign * h.q;
            if (!c->carrier_off) { s->eps = s->k_norm * s->i_h.q; }   /* eqs. (6)-(7) */
        }
    }
    (void)fs_pll_step(&s->pll, s->eps);                           /* Fig. 1 */
    const float th = s->pll.theta;

    /* compensation of the cross-saturation lead, on the q current in the
     * output frame of the last step */
    s->delta = 0.0f;
    if (fs_xcomp_active(&c->xcomp)) {
        const float i_q = -s->i_f.alpha * fs_sinf(s->theta) + (s->i_f.beta * fs_cosf(s->theta));
        s->delta = fs_xcomp_eval(&c->xcomp, i_q);
    }
    s->theta = fs_wrap_pi(th - s->delta);
    s->w = (s->pll.k_p * s->eps) + s->pll.integ;   /* Fig. 1: the PI's output, the angle's rate */

    /* eq. (4) for the interval starting at j = k + delay: + in phases 3 and
     * 0, - in 1 and 2 (edges at the odd samples); from j = 2 on, so that the
     * first half is one interval long and the triangle has no offset */
    const long long j = s->k + c->delay;
    const int m = (int)(j & 3);
    s->theta_u[m] = th;
    const float u = ((j < 2) || c->carrier_off) ? 0.0f : (((m == 3) || (m == 0)) ? c->u_h : -c->u_h);
    s->u.alpha = u * fs_cosf(th);
    s->u.beta = u * fs_sinf(th);
    ++s->k;
    return s->theta;
}
