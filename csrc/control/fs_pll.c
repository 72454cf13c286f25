#include "fs_pll.h"
#include "fs_math.h"

FS_COLD fs_status fs_pll_init(fs_pll *pll, const fs_pll_config *cfg)
{
    fs_status ret;
    if (!pll || !cfg) { ret = FS_ERR_NULL; }
    else if (!fs_pos(cfg->Ts)) { ret = FS_ERR_TS; }
    else if (!(cfg->bandwidth > 0.0f) || !((cfg->bandwidth * cfg->Ts) <= 0.5f)) { ret = FS_ERR_BANDWIDTH; }
    else if (!fs_fin(cfg->w_max)) { ret = FS_ERR_LIMIT; }
    else {
        pll->cfg = *cfg;
        pll->k_p = 2.0f * cfg->bandwidth;               /* eq. (13), poles at -w_b */
        pll->k_i = cfg->bandwidth * cfg->bandwidth;
        fs_pll_reset(pll, 0.0f, 0.0f);
        ret = FS_OK;
    }
    return ret;
}

void fs_pll_reset(fs_pll *pll, float theta, float w)
{
    pll->theta = fs_wrap_pi(theta);
    pll->w = w;
    pll->integ = w;
}

float fs_pll_step(fs_pll *pll, float err)
{
    pll->integ += pll->cfg.Ts * pll->k_i * err;
    if (pll->cfg.w_max > 0.0f) {
        pll->integ = fs_clamp_sym(pll->integ, pll->cfg.w_max);
    }
    /* The angle moves with k_p err + integral; the speed estimate is the
     * integral alone, which the loop filters (no proportional noise). */
    pll->w = pll->integ;
    pll->theta = fs_wrap_pi(pll->theta + (pll->cfg.Ts * ((pll->k_p * err) + pll->integ)));
    return pll->theta;
}
