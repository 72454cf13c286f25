#include "fs_param_adapt.h"
#include "fs_math.h"

FS_COLD fs_status fs_param_adapt_init(fs_param_adapt *a, const fs_param_adapt_config *cfg)
{
    fs_status ret;
    if (!a || !cfg) { ret = FS_ERR_NULL; }
    else if (!fs_pos(cfg->Ts)) { ret = FS_ERR_TS; }
    else if (!fs_nonneg(cfg->R_s)) { ret = FS_ERR_RS; }
    else if (!fs_pos(cfg->L_d)) { ret = FS_ERR_LD; }
    else if (!fs_pos(cfg->psi_f)) { ret = FS_ERR_PSI_F; }
    else if (!fs_pos(cfg->i_max) || !fs_pos(cfg->w_e_max)) { ret = FS_ERR_LIMIT; }
    else if (!fs_nonneg(cfg->w_lp) || !fs_nonneg(cfg->min_sep) || !(cfg->min_sep < 1.0f) || !fs_nonneg(cfg->min_level)) {
        ret = FS_ERR_PARAM;
    }
    else {
        a->cfg = *cfg;
        /* 1 ms between updates: the window is seconds long, and the float sums
         * lose less to rounding with lambda further from 1 */
        a->decim = (int)fs_maxf(1.0f, roundf(1e-3f / cfg->Ts));
        const float T_u = (float)a->decim * cfg->Ts;
        if (!fs_pos(cfg->T_f) || !(cfg->T_f >= (20.0f * T_u)) || !(cfg->T_f <= (1e7f * T_u))) { ret = FS_ERR_PARAM; }
        else {
            a->lambda = fs_exp_pole(-T_u / cfg->T_f);
            a->n_fill = fs_ceil_int(cfg->T_f / T_u);
            /* 20 rad/s: -50 dB at a 1 kHz injection carrier, and a lag of 50 ms,
             * short against the seconds a drive cycle holds a point */
            if (a->cfg.w_lp <= 0.0f) { a->cfg.w_lp = 20.0f; }
            if (a->cfg.min_sep <= 0.0f) { a->cfg.min_sep = 0.05f; }
            if (a->cfg.min_level <= 0.0f) { a->cfg.min_level = 0.01f; }
            a->a_lp = -expm1f(-a->cfg.w_lp * cfg->Ts);
            fs_param_adapt_reset(a);
            ret = FS_OK;
        }
    }
    return ret;
}

void fs_param_adapt_reset(fs_param_adapt *a)
{
    a->k = 0;
    a->n_learn = 0;
    a->y = 0.0f;
    a->i_q = 0.0f;
    a->w = 0.0f;
    a->S11 = 0.0f;
    a->S12 = 0.0f;
    a->S22 = 0.0f;
    a->b1 = 0.0f;
    a->b2 = 0.0f;
    a->R_s = a->cfg.R_s;
    a->psi_f = a->cfg.psi_f;
    a->sep = 0.0f;
    a->updating = false;
}

bool fs_param_adapt_step(fs_param_adapt *a, fs_dq u, fs_dq i, float w_e, bool learn)
{
    bool ret;
    const fs_param_adapt_config *c = &a->cfg;
    /* eq. (A)'s left side and regressors, low-passed alike */
    const float y = u.q - (w_e * c->L_d * i.d);
    a->y += a->a_lp * (y - a->y);
    a->i_q += a->a_lp * (i.q - a->i_q);
    a->w += a->a_lp * (w_e - a->w);
    if (++a->k < a->decim) { ret = false; }
    else {
        a->k = 0;
        if (!learn) { ret = false; }
        else {
            const float p1 = a->i_q / c->i_max;
            const float p2 = a->w / c->w_e_max;
            const float l = a->lambda;
            a->S11 = (l * a->S11) + (p1 * p1);
            a->S12 = (l * a->S12) + (p1 * p2);
            a->S22 = (l * a->S22) + (p2 * p2);
            a->b1 = (l * a->b1) + (p1 * a->y);
            a->b2 = (l * a->b2) + (p2 * a->y);
            const float det = (a->S11 * a->S22) - (a->S12 * a->S12);
            const float sq = a->S11 * a->S22;
            a->sep = 0.0f;
            if (sq > 0.0f) { a->sep = det / sq; }
            /* the window's mean |phi|^2: its sum times (1 - lambda) */
            const float level = (a->S11 + a->S22) * (1.0f - l);
            if (a->n_learn < a->n_fill) { ++a->n_learn; }
            a->updating = (a->n_learn >= a->n_fill) && (a->sep >= c->min_sep) && (level >= c->min_level);
            if (!a->updating) { ret = false; }
            else {
                /* theta = S^-1 b, in volts at i_max and w_e_max */
                const float t1 = ((a->S22 * a->b1) - (a->S12 * a->b2)) / det;
                const float t2 = ((a->S11 * a->b2) - (a->S12 * a->b1)) / det;
                a->R_s = fs_clampf(t1 / c->i_max, 0.5f * c->R_s, 3.0f * c->R_s);
                a->psi_f = fs_clampf(t2 / c->w_e_max, 0.5f * c->psi_f, 1.5f * c->psi_f);
                ret = true;
            }
        }
    }
    return ret;
}
