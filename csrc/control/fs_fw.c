#include "fs_fw.h"
#include "fs_math.h"

FS_COLD fs_status fs_fw_init(fs_fw *fw, const fs_fw_config *cfg)
{
    if (!fw || !cfg) { return FS_ERR_NULL; }
    if (!fs_pos(cfg->Ts)) { return FS_ERR_TS; }
    if (!fs_pos(cfg->L)) { return FS_ERR_LD; }
    if (!fs_pos(cfg->w_e_max)) { return FS_ERR_LIMIT; }
    if (!fs_pos(cfg->gain)) { return FS_ERR_PARAM; }
    if (!(cfg->bandwidth > 0.0f) || !(cfg->bandwidth * cfg->Ts <= 1.0f)) { return FS_ERR_BANDWIDTH; }
    if (!fs_pos(cfg->i_max)) { return FS_ERR_I_MAX; }
    fw->cfg = *cfg;
    float wl = cfg->w_e_max * cfg->L;
    fw->beta = cfg->gain / (wl * wl);            /* eq. (31) */
    if (!fs_fin(fw->beta)) { return FS_ERR_PARAM; }   /* w_e,max L too small for a float */
    fw->a = fs_exp_pole(-cfg->bandwidth * cfg->Ts);
    fs_fw_reset(fw);
    return FS_OK;
}

FS_COLD void fs_fw_design(fs_fw_config *cfg, float bw_current, bool hold)
{
    if (!cfg) { return; }
    const float K = fs_minf(0.25f * bw_current, 1.5f * cfg->w_e_max);   /* held: fs_drive.h */
    if (!(cfg->gain > 0.0f)) { cfg->gain = hold ? K / bw_current : 50.0f; }
    if (!(cfg->bandwidth > 0.0f)) {
        cfg->bandwidth = hold ? cfg->gain * bw_current
                              : fs_minf(0.25f * bw_current, 0.5f * cfg->w_e_max) / cfg->gain;
    }
}

void fs_fw_reset(fs_fw *fw) { fw->i_d = 0.0f; }

float fs_fw_step(fs_fw *fw, float dv_q, float w_e)
{
    const fs_fw_config *c = &fw->cfg;
    float x = -fw->beta * w_e * c->L * dv_q;     /* eq. (28): -beta grad F */
    fw->i_d = fw->a * fw->i_d + (1.0f - fw->a) * x;   /* eq. (30), exact ZOH low-pass */
    fw->i_d = fs_clampf(fw->i_d, -c->i_max, 0.0f);
    return fw->i_d;
}

fs_dq fs_fw_hold(const fs_fw *fw, fs_dq u_ref, fs_dq u_real, float w_e)
{
    const fs_dq dv = {u_ref.d - u_real.d, u_ref.q - u_real.q};
    const float use = fw->beta * w_e * fw->cfg.L * dv.q;   /* eq. (30)'s input, A: > 0 weakens */
    float s = 0.0f;
    if (use > 0.0f) { s = fw->i_d > -fw->cfg.i_max ? 1.0f : fs_minf(1.0f, fw->cfg.i_max / use); }
    return (fs_dq){u_real.d + s * dv.d, u_real.q + s * dv.q};
}
