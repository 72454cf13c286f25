#include "fs_lock.h"
#include "fs_math.h"

FS_COLD fs_status fs_lock_init(fs_lock *lk, const fs_lock_config *cfg)
{
    if (!lk || !cfg) { return FS_ERR_NULL; }
    if (!fs_pos(cfg->Ts)) { return FS_ERR_TS; }
    if (!(cfg->t_lost >= cfg->Ts) || !fs_fin(cfg->t_lost)) { return FS_ERR_LIMIT; }
    lk->cfg = *cfg;
    fs_lock_reset(lk);
    return FS_OK;
}

FS_COLD void fs_lock_reset(fs_lock *lk)
{
    lk->t_over = 0.0f;
    lk->lost = false;
}

bool fs_lock_step(fs_lock *lk, float r)
{
    /* a NaN residual counts as above, at the most; above 1 each step
     * counts as far as r is over, up to twice (FS_LOCK_R_MAX) */
    bool over = !(r <= 1.0f);
    const float wgt = r < FS_LOCK_R_MAX ? r : FS_LOCK_R_MAX;
    lk->t_over = over ? lk->t_over + wgt * lk->cfg.Ts : fs_maxf(lk->t_over - lk->cfg.Ts, 0.0f);
    if (lk->t_over >= lk->cfg.t_lost) { lk->lost = true; }
    return lk->lost;
}

void fs_lock_latch(fs_lock *lk)
{
    lk->lost = true;
}
