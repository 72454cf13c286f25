#include "fs_thermal.h"

#include <math.h>

static int pos(double x) { return x > 0.0 && isfinite(x); }
static int in_range(double x, double lo, double hi) { return x >= lo && x <= hi; }

fs_status fs_thermal_init(fs_thermal *th, const fs_thermal_config *cfg)
{
    if (!th || !cfg) return FS_ERR_NULL;
    th->cfg = *cfg;
    th->T_w = cfg->T_w0;
    th->T_m = cfg->T_m0;
    th->P_cu = th->P_fe = 0.0;
    if (!cfg->enabled) return FS_OK;
    if (!pos(cfg->R_wa) || !pos(cfg->R_wm) || !pos(cfg->R_ma) || !pos(cfg->C_w) || !pos(cfg->C_m))
        return FS_ERR_PARAM;
    if (!(cfg->time_scale >= 1.0) || !isfinite(cfg->time_scale)) return FS_ERR_PARAM;
    if (!in_range(cfg->k_rotor, 0.0, 1.0)) return FS_ERR_PARAM;
    if (fs_iron_check(&cfg->iron) != FS_OK) return FS_ERR_PARAM;
    if (!(fabs(cfg->alpha_cu) < 0.1) || !(fabs(cfg->alpha_br) < 0.1)) return FS_ERR_PARAM;
    const double T[4] = {cfg->T_amb, cfg->T_ref, cfg->T_w0, cfg->T_m0};
    for (int k = 0; k < 4; ++k)
        if (!in_range(T[k], -273.15, 1000.0)) return FS_ERR_PARAM;
    /* the factors stay positive over any temperature a machine sees */
    for (double t = -50.0; t <= 300.0; t += 350.0) {
        if (!(1.0 + cfg->alpha_cu * (t - cfg->T_ref) > 0.0)) return FS_ERR_PARAM;
        if (!(1.0 + cfg->alpha_br * (t - cfg->T_ref) > 0.0)) return FS_ERR_PARAM;
    }
    return FS_OK;
}

void fs_thermal_step(fs_thermal *th, double P_cu, double P_fe, double dt)
{
    const fs_thermal_config *c = &th->cfg;
    th->P_cu = P_cu;
    th->P_fe = P_fe;
    /* backward Euler: (C/dt + G) T+ = C/dt T + P + G_amb T_amb, a 2 x 2 solve */
    const double cw = c->C_w / (c->time_scale * dt), cm = c->C_m / (c->time_scale * dt);
    const double g_wa = 1.0 / c->R_wa, g_wm = 1.0 / c->R_wm, g_ma = 1.0 / c->R_ma;
    const double a11 = cw + g_wa + g_wm, a12 = -g_wm, a22 = cm + g_ma + g_wm;
    const double b1 = cw * th->T_w + P_cu + (1.0 - c->k_rotor) * P_fe + g_wa * c->T_amb;
    const double b2 = cm * th->T_m + c->k_rotor * P_fe + g_ma * c->T_amb;
    const double det = a11 * a22 - a12 * a12;
    th->T_w = (a22 * b1 - a12 * b2) / det;
    th->T_m = (a11 * b2 - a12 * b1) / det;
}

double fs_thermal_r_factor(const fs_thermal *th)
{
    return 1.0 + th->cfg.alpha_cu * (th->T_w - th->cfg.T_ref);
}

double fs_thermal_magnet_factor(const fs_thermal *th)
{
    return 1.0 + th->cfg.alpha_br * (th->T_m - th->cfg.T_ref);
}
