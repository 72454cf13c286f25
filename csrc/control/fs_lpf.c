#include "fs_lpf.h"
#include "fs_math.h"

FS_COLD fs_status fs_lpf_init(fs_lpf *f, const fs_lpf_config *cfg)
{
    if (!f || !cfg) { return FS_ERR_NULL; }
    if (!fs_pos(cfg->Ts)) { return FS_ERR_TS; }
    if (!fs_pos(cfg->w_c_min)) { return FS_ERR_BANDWIDTH; }
    f->cfg = *cfg;
    fs_lpf_reset(f);
    return FS_OK;
}

void fs_lpf_reset(fs_lpf *f) { f->y.alpha = 0.0f; f->y.beta = 0.0f; }

float fs_lpf_gain(const fs_lpf *f, float w_c)
{
    const float wc = fs_maxf(fabsf(w_c), f->cfg.w_c_min);
    return wc * f->cfg.Ts / (1.0f + (wc * f->cfg.Ts));   /* backward Euler */
}

fs_ab fs_lpf_step_gain(fs_lpf *f, fs_ab x, float g)
{
    f->y.alpha += g * (x.alpha - f->y.alpha);
    f->y.beta += g * (x.beta - f->y.beta);
    return f->y;
}

fs_ab fs_lpf_step(fs_lpf *f, fs_ab x, float w_c) { return fs_lpf_step_gain(f, x, fs_lpf_gain(f, w_c)); }
