#include "fs_pi.h"
#include "fs_math.h"

FS_COLD fs_status fs_pi_init(fs_pi *pi, const fs_pi_config *cfg)
{
    fs_status ret;
    if (!pi || !cfg) { ret = FS_ERR_NULL; }
    else if (!fs_pos(cfg->Ts)) { ret = FS_ERR_TS; }
    else if (!fs_nonneg(cfg->k_p) || !fs_nonneg(cfg->k_i) || !fs_nonneg(cfg->k_t) || !fs_fin(cfg->u_max)) {
        ret = FS_ERR_PARAM;
    }
    else {
        pi->cfg = *cfg;
        pi->k_i_Ts = cfg->Ts * cfg->k_i;
        fs_pi_reset(pi);
        ret = FS_OK;
    }
    return ret;
}

FS_COLD fs_status fs_pi_design(fs_pi_config *cfg, float Ts, float L, float R, float alpha, float u_max)
{
    fs_status ret;
    if (!cfg) { ret = FS_ERR_NULL; }
    else if (!fs_pos(Ts)) { ret = FS_ERR_TS; }
    else if (!fs_pos(L) || !fs_nonneg(R) || !fs_fin(u_max)) { ret = FS_ERR_PARAM; }
    else if (!(alpha > 0.0f) || !((alpha * Ts) <= 2.0f)) { ret = FS_ERR_BANDWIDTH; }
    else {
        /* r = 1 - a and q = 1 - p by expm1f, which keeps them exact when small */
        float r = -expm1f(-R * Ts / L);
        float q = -expm1f(-alpha * Ts);
        float b;
        if ((R > 0.0f) && (r > 0.0f)) { b = r / R; }
        else { b = Ts / L; }
        cfg->Ts = Ts;
        cfg->k_t = q / b;
        cfg->k_p = fs_maxf(((2.0f * q) - r) / b, 0.0f);  /* (1 + a - 2p) / b */
        cfg->k_i = q * q / (b * Ts);
        cfg->u_max = u_max;
        /* gains beyond the float range (L / Ts or R / (1 - a) too large) */
        ret = fs_fin(cfg->k_t) && fs_fin(cfg->k_i) ? FS_OK : FS_ERR_PARAM;
    }
    return ret;
}

FS_COLD fs_status fs_pi_design_init(fs_pi *pi, float Ts, float L, float R, float alpha, float u_max)
{
    fs_pi_config c;
    fs_status st = fs_pi_design(&c, Ts, L, R, alpha, u_max);
    if (st == FS_OK) { st = fs_pi_init(pi, &c); }
    return st;
}

void fs_pi_reset(fs_pi *pi) { pi->integ = 0.0f; }

float fs_pi_output(const fs_pi *pi, float ref, float meas)
{
    return (pi->cfg.k_t * ref) - (pi->cfg.k_p * meas) + pi->integ;
}

void fs_pi_update(fs_pi *pi, float ref, float meas, float u, float u_real)
{
    pi->integ += pi->k_i_Ts * (ref - meas) + (u_real - u);
}

float fs_pi_step(fs_pi *pi, float ref, float meas)
{
    float u = fs_pi_output(pi, ref, meas);
    float u_real = u;
    if (pi->cfg.u_max > 0.0f) {
        u_real = fs_clamp_sym(u, pi->cfg.u_max);
    }
    fs_pi_update(pi, ref, meas, u, u_real);
    return u_real;
}
