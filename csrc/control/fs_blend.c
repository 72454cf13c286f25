#include "fs_blend.h"
#include "fs_blend_angle.h"
#include "fs_math.h"

float fs_blend_weight(float w, float w_lower, float w_upper)
{
    const float aw = fabsf(w);  /* eq. (28) */
    if (aw <= w_lower) { return 0.0f; }
    if (aw >= w_upper) { return 1.0f; }
    return fs_clamp01((aw - w_lower) / (w_upper - w_lower));
}

float fs_blend_angle(float theta_smo, float theta_hfi, float g)
{
    return fs_blend_angle_inline(theta_smo, theta_hfi, g);
}

FS_COLD fs_status fs_blend_init(fs_blend *b, const fs_blend_config *cfg)
{
    if (!b || !cfg) { return FS_ERR_NULL; }
    if (!(cfg->w_lower >= 0.0f) || !(cfg->w_upper > cfg->w_lower) || !isfinite(cfg->w_upper)) {
        return FS_ERR_LIMIT;
    }
    if (cfg->gate != 0 && cfg->gate != 1) { return FS_ERR_PARAM; }
    fs_status st = fs_motion_obs_init(&b->obs, &cfg->obs);
    if (st != FS_OK) { return st; }
    b->cfg = *cfg;
    b->d_trust = 0.25f * cfg->obs.bandwidth * cfg->obs.Ts;
    fs_blend_reset(b, 0.0f, 0.0f);
    return FS_OK;
}

FS_COLD void fs_blend_reset(fs_blend *b, float theta, float w)
{
    fs_motion_obs_reset(&b->obs, theta, w);
    b->theta_hat = b->obs.theta_hat;
    b->w_hat = b->obs.w_hat;
    b->theta_blnd = b->theta_hat;
    b->g_w = fs_blend_weight(w, b->cfg.w_lower, b->cfg.w_upper);
    b->trust = 1.0f;   /* the caller resets from an angle it trusts */
}

void fs_blend_follow(fs_blend *b, float theta, float w, float T_d)
{
    fs_motion_obs_reset(&b->obs, theta, w);
    b->obs.T_d_hat = T_d;
    b->theta_hat = b->theta_blnd = b->obs.theta_hat;
    b->w_hat = b->obs.w_hat;
}

float fs_blend_step(fs_blend *b, float theta_smo, float theta_hfi, float T_ff)
{
    return fs_blend_step_gated(b, theta_smo, theta_hfi, T_ff, true, false);
}

float fs_blend_step_gated(fs_blend *b, float theta_smo, float theta_hfi, float T_ff, bool smo_converged, bool hfi_live)
{
    /* Fig. 6: the weight from the observer's speed, eq. (28) */
    b->g_w = fs_blend_weight(b->obs.w_hat, b->cfg.w_lower, b->cfg.w_upper);
    const bool smo_ok = smo_converged;
    /* the gate (header): the trust in the SMO falls at once and comes back
     * over 4 / w_o, so that a gate that opens and closes cannot make the
     * weight chatter through the band */
    if (hfi_live) { b->trust = smo_ok ? fs_minf(b->trust + b->d_trust, 1.0f) : 0.0f; }
    else { b->trust = 1.0f; }
    b->g_w *= b->trust;
    b->theta_blnd = fs_blend_angle_inline(theta_smo, theta_hfi, b->g_w);  /* eq. (27) */
    (void)fs_motion_obs_step(&b->obs, fs_wrap_pi(b->theta_blnd - b->obs.theta_hat), T_ff);
    b->theta_hat = b->obs.theta_hat;
    b->w_hat = b->obs.w_hat;
    return b->theta_hat;
}
