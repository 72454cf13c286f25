#include "fs_lpf.h"
#include "fs_math.h"

FS_COLD fs_status fs_lpf_init(fs_lpf *f, const fs_lpf_config *cfg)
{
    fs_status ret;
    if (!f || !cfg) { ret = FS_ERR_NULL; }
    else if (!fs_pos(cfg->Ts)) { ret = FS_ERR_TS; }
    else if (!fs_pos(cfg->w_c_min)) { ret = FS_ERR_BANDWIDTH; }
    else {
        f->cfg = *cfg;
        fs_lpf_reset(f);
        ret = FS_OK;
    }
    return ret;
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
