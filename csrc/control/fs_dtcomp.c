#include "fs_dtcomp.h"
#include "fs_math.h"
#include "fs_vsd.h"

FS_COLD fs_status fs_dtcomp_init(fs_dtcomp *d, const fs_dtcomp_config *cfg)
{
    fs_status ret;
    if (!d || !cfg) { ret = FS_ERR_NULL; }
    else {
        const fs_dtcomp_config *c = cfg;
        if ((c->phases != 3) && (c->phases != 5)) { ret = FS_ERR_PARAM; }
        else if (!fs_pos(c->T_pwm)) { ret = FS_ERR_TS; }
        else {
            const bool dbl = fabsf(c->Ts - (0.5f * c->T_pwm)) <= (1e-6f * c->T_pwm);
            if (!dbl && !(fabsf(c->Ts - c->T_pwm) <= (1e-6f * c->T_pwm))) { ret = FS_ERR_TS; }
            else if ((c->delay != 0.0f) && (c->delay != 1.0f)) { ret = FS_ERR_PARAM; }
            else if (!fs_pos(c->t_dead) || !(c->t_dead < (0.5f * c->T_pwm)) || !fs_nonneg(c->i_band)) { ret = FS_ERR_PARAM; }
            else if (!fs_pos(c->L_d)) { ret = FS_ERR_LD; }
            else if (!fs_pos(c->L_q)) { ret = FS_ERR_LQ; }
            else {
                d->cfg = *cfg;
                d->inv_L = 2.0f / (c->L_d + c->L_q);
                d->dd = c->t_dead / c->T_pwm;
                d->double_update = 0;
                if (dbl) { d->double_update = 1; }
                fs_dtcomp_reset(d);
                ret = FS_OK;
            }
        }
    }
    return ret;
}

FS_COLD void fs_dtcomp_reset(fs_dtcomp *d)
{
    d->k = 0;
    d->u_inj_now.alpha = 0.0f;
    d->u_inj_now.beta = 0.0f;
}

/* The part of a current's sign that loses (pos) or gains (neg) dead time. */
static float pos_part(float i, float band)
{
    return (band > 0.0f) ? fs_clampf(i / band, 0.0f, 1.0f) : ((i > 0.0f) ? 1.0f : 0.0f);   /* mostly outside: both ends */
}

/* Each phase's share of a stationary vector (the amplitude-invariant inverse).
 * Inline: its two calls a step while the carrier runs cost 6.4 instructions a
 * step of the blended run as calls (bench/pil.py, firmware build). */
static inline void phase_values(int phases, fs_ab v, float out[])
{
    if (phases == 5) {
        fs_vsd5 p = {v, {0.0f, 0.0f}, 0.0f};
        fs_vsd5_inverse(&p, out);
    } else {
        fs_inv_clarke(v, out);
    }
}

void fs_dtcomp_sampled(int phases, const float i_ph[], float dd, float i_band, float duty[])
{
    for (int k = 0; k < phases; ++k) {
        const float dk = duty[k];
        if (!((dk > 0.0f) && (dk < 1.0f))) { continue; }
        const float s = (i_band > 0.0f) ? fs_clamp_sym(i_ph[k] / i_band, 1.0f) : fs_signf(i_ph[k]);
        duty[k] = fs_clamp01(dk + (s * dd));
    }
}

void fs_dtcomp_step(fs_dtcomp *d, const float i_ph[], fs_ab u_inj, float duty[])
{
    const fs_dtcomp_config *c = &d->cfg;
    const bool carrier = (u_inj.alpha != 0.0f) || (u_inj.beta != 0.0f) || (d->u_inj_now.alpha != 0.0f) || (d->u_inj_now.beta != 0.0f);
    if (!carrier && !d->double_update) {   /* both edges at the sample's current (header) */
        fs_dtcomp_sampled(c->phases, i_ph, d->dd, c->i_band, duty);
        ++d->k;
    }
    else {
        const float Th = 0.5f * c->T_pwm;
        /* flux the carrier adds until the interval starts, and its rate in it */
        const float t0 = c->delay * c->Ts;
        float di0[FS_PHASES_MAX];
        float rate[FS_PHASES_MAX];
        phase_values(c->phases, (fs_ab){t0 * d->inv_L * d->u_inj_now.alpha, t0 * d->inv_L * d->u_inj_now.beta}, di0);
        phase_values(c->phases, (fs_ab){u_inj.alpha * d->inv_L, u_inj.beta * d->inv_L}, rate);
        /* the half the interval is: with delay it starts one step after this one */
        const int half = d->double_update ? (int)((d->k + (int)c->delay) & 1) : -1;
        for (int k = 0; k < c->phases; ++k) {
            const float dk = duty[k];
            if (!((dk > 0.0f) && (dk < 1.0f))) { continue; }   /* no edge, no dead time */
            const float i0 = i_ph[k] + di0[k];
            float dd = 0.0f;
            if (half != 1) {   /* the rising edge: the first half of the interval */
                const float tau = ((1.0f - dk) * Th) + (0.5f * c->t_dead);
                dd += pos_part(i0 + (tau * rate[k]), c->i_band);
            }
            if (half != 0) {   /* the falling edge: in the second half (a period's, or the interval's own) */
                const float tau = ((half < 0) ? Th : 0.0f) + (dk * Th) + (0.5f * c->t_dead);
                dd -= pos_part(-(i0 + (tau * rate[k])), c->i_band);
            }
            duty[k] = fs_clamp01(dk + (dd * c->t_dead / ((half < 0) ? c->T_pwm : Th)));
        }
        d->u_inj_now = u_inj;
        ++d->k;
    }
}
