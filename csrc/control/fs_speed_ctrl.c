#include "fs_speed_ctrl.h"
#include "fs_math.h"

FS_COLD fs_status fs_speed_ctrl_init(fs_speed_ctrl *sc, const fs_speed_ctrl_config *cfg)
{
    if (!sc || !cfg) { return FS_ERR_NULL; }
    if (!fs_pos(cfg->Ts)) { return FS_ERR_TS; }
    if (!fs_pos(cfg->J)) { return FS_ERR_J; }
    if (!fs_nonneg(cfg->B)) { return FS_ERR_PARAM; }
    if (!(cfg->bandwidth > 0.0f) || !(cfg->bandwidth * cfg->Ts <= 0.5f)) { return FS_ERR_BANDWIDTH; }
    if (!fs_pos(cfg->T_max)) { return FS_ERR_LIMIT; }
    sc->cfg = *cfg;
    const bool explicit = cfg->k_p != 0.0f || cfg->k_i != 0.0f;
    if (explicit && !(fs_pos(cfg->k_p) && fs_nonneg(cfg->k_i))) { return FS_ERR_PARAM; }
    fs_pi_config c = {cfg->Ts, cfg->k_p, cfg->k_p, cfg->k_i, cfg->T_max};
    fs_status st = explicit ? FS_OK : fs_pi_design(&c, cfg->Ts, cfg->J, cfg->B, cfg->bandwidth, cfg->T_max);
    if (st != FS_OK) { return st; }
    return fs_pi_init(&sc->pi, &c);
}

void fs_speed_ctrl_reset(fs_speed_ctrl *sc) { fs_pi_reset(&sc->pi); }

float fs_speed_ctrl_step(fs_speed_ctrl *sc, float w_m_ref, float w_m)
{
    return fs_pi_step(&sc->pi, w_m_ref, w_m);
}

void fs_speed_ctrl_preset(fs_speed_ctrl *sc, float w_m, float T)
{
    /* u = k_t r - k_p y + I with r = y = w_m */
    sc->pi.integ = T - (sc->pi.cfg.k_t - sc->pi.cfg.k_p) * w_m;
}

void fs_speed_ctrl_realised(fs_speed_ctrl *sc, float T_ref, float T_real)
{
    sc->pi.integ += T_real - T_ref;
}
