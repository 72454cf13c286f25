#include "fs_polarity.h"
#include "fs_math.h"

fs_status fs_polarity_init(fs_polarity *p, const fs_polarity_config *cfg)
{
    if (!p || !cfg) return FS_ERR_NULL;
    if (!fs_pos(cfg->Ts)) return FS_ERR_TS;
    if (!fs_pos(cfg->i_pulse)) return FS_ERR_I_MAX;
    /* the step counts must stay ints: below 1e9 */
    if (!(cfg->t_lock >= 0.0f) || !(cfg->t_pulse >= 4.0f * cfg->Ts) || !(cfg->t_lock + cfg->t_pulse < 1e3f)
        || !((cfg->t_lock + cfg->t_pulse) / cfg->Ts < 1e9f))
        return FS_ERR_PARAM;
    p->cfg = *cfg;
    p->n_lock = (int)(cfg->t_lock / cfg->Ts + 0.5f);
    p->n_pulse = (int)(cfg->t_pulse / cfg->Ts + 0.5f);
    fs_polarity_reset(p);
    return FS_OK;
}

void fs_polarity_reset(fs_polarity *p)
{
    p->stage = p->n_lock > 0 ? FS_POLARITY_LOCK : FS_POLARITY_POS;
    p->k = 0;
    p->sum_pos = p->sum_neg = 0.0f;
    p->i_p_pos = p->i_p_neg = 0.0f;
    p->flip = false;
}

float fs_polarity_step(fs_polarity *p, float i_p)
{
    const int half = p->n_pulse / 2;
    switch (p->stage) {
    case FS_POLARITY_LOCK:
        if (++p->k >= p->n_lock) {
            p->stage = FS_POLARITY_POS;
            p->k = 0;
            return p->cfg.i_pulse;
        }
        return 0.0f;
    case FS_POLARITY_POS:
        if (p->k >= half) p->sum_pos += i_p;
        if (++p->k >= p->n_pulse) {
            p->i_p_pos = p->sum_pos / (float)(p->n_pulse - half);
            p->stage = FS_POLARITY_NEG;
            p->k = 0;
            return -p->cfg.i_pulse;
        }
        return p->cfg.i_pulse;
    case FS_POLARITY_NEG:
        if (p->k >= half) p->sum_neg += i_p;
        if (++p->k >= p->n_pulse) {
            p->i_p_neg = p->sum_neg / (float)(p->n_pulse - half);
            p->flip = p->i_p_pos < p->i_p_neg;
            p->stage = FS_POLARITY_DONE;
            return 0.0f;
        }
        return -p->cfg.i_pulse;
    default:
        return 0.0f;
    }
}
