#include "fs_polarity.h"
#include "fs_math.h"

FS_COLD fs_status fs_polarity_init(fs_polarity *p, const fs_polarity_config *cfg)
{
    if (!p || !cfg) { return FS_ERR_NULL; }
    if (!fs_pos(cfg->Ts)) { return FS_ERR_TS; }
    if (!fs_pos(cfg->i_pulse)) { return FS_ERR_I_MAX; }
    /* the step counts must stay ints: below 1e9 */
    if (!(cfg->t_lock >= 0.0f) || !(cfg->t_pulse >= 4.0f * cfg->Ts) || !(cfg->t_lock + cfg->t_pulse < 1e3f)
        || !((cfg->t_lock + cfg->t_pulse) / cfg->Ts < 1e9f)) {
        return FS_ERR_PARAM;
    }
    if (!fs_fin(cfg->i_pulse_max) || !(cfg->i_pulse_max == 0.0f || cfg->i_pulse_max >= cfg->i_pulse)) { return FS_ERR_I_MAX; }
    if (!fs_fin(cfg->d_min) || !(cfg->d_min >= 0.0f && cfg->d_min < 1.0f)) { return FS_ERR_PARAM; }
    if (!fs_fin(cfg->w_filter) || !(cfg->w_filter >= 0.0f)) { return FS_ERR_BANDWIDTH; }
    if (cfg->n_carrier < 0) { return FS_ERR_PARAM; }
    if (!fs_fin(cfg->w_max) || !(cfg->w_max >= 0.0f)) { return FS_ERR_PARAM; }
    p->cfg = *cfg;
    if (p->cfg.i_pulse_max == 0.0f) { p->cfg.i_pulse_max = cfg->i_pulse; }
    if (p->cfg.d_min == 0.0f) { p->cfg.d_min = FS_POLARITY_D_MIN; }
    if (p->cfg.w_max == 0.0f) { p->cfg.w_max = FS_POLARITY_W_MAX_PER_FILTER * cfg->w_filter; }   /* stays 0 (no check) without it */
    const float lock_steps = (cfg->t_lock / cfg->Ts) + 0.5f;   /* rounded by the truncation to int */
    p->n_lock = (int)lock_steps;
    const float pulse_steps = (cfg->t_pulse / cfg->Ts) + 0.5f;
    p->n_pulse = (int)pulse_steps;
    /* the second half of each pulse, in whole carrier periods when one fits */
    const int half = p->n_pulse - p->n_pulse / 2;
    const bool whole = cfg->n_carrier > 1 && half >= cfg->n_carrier;
    p->n_avg = whole ? half - half % cfg->n_carrier : half;
    p->n_per = whole ? cfg->n_carrier : 1;
    fs_polarity_reset(p);
    return FS_OK;
}

/* The carrier periods a pulse's averaging window holds (n_avg / n_per):
 * the number of the means the spread is taken over */
static inline int polarity_periods(const fs_polarity *p) { return p->n_avg / p->n_per; }

static void polarity_pulses(fs_polarity *p)
{
    p->stage = FS_POLARITY_POS;
    p->k = 0;
    p->sum_pos = p->sum_neg = p->sq_pos = p->sq_neg = 0.0f;
    p->acc = 0.0f;
    p->w_peak = p->w_sum = p->w_prev = 0.0f;
    p->halves = 0;
}

FS_COLD void fs_polarity_reset(fs_polarity *p)
{
    polarity_pulses(p);
    p->stage = p->n_lock > 0 ? FS_POLARITY_LOCK : FS_POLARITY_POS;
    p->i_now = p->cfg.i_pulse;
    p->attempts = 0;
    p->ref_pos = p->ref_neg = 0.0f;
    p->i_p_pos = p->i_p_neg = 0.0f;
    p->d = p->margin = 0.0f;
    p->flip = p->moved = false;
}

/* The decision on one pair of pulses: D, its noise, the margin; DONE,
 * another pair with a larger pulse, or UNDETERMINED. */
static void polarity_decide(fs_polarity *p)
{
    /* the spread of the carrier periods' means: the ripple, which repeats
     * every period, is not in it; noise and drift are */
    const float n = (float)polarity_periods(p);
    const float mean = 0.5f * (p->i_p_pos + p->i_p_neg);
    const float var_pos = fs_maxf(p->sq_pos / n - (p->i_p_pos - p->ref_pos) * (p->i_p_pos - p->ref_pos), 0.0f);
    const float var_neg = fs_maxf(p->sq_neg / n - (p->i_p_neg - p->ref_neg) * (p->i_p_neg - p->ref_neg), 0.0f);
    /* independent ones among them: at most n, about 2 per 1 / w_filter */
    const float T_per = (float)p->n_per * p->cfg.Ts;
    const float n_eff = p->cfg.w_filter > 0.0f ? fs_clampf(0.5f * n * T_per * p->cfg.w_filter, 1.0f, n) : n;
    const float sigma_d = mean > 0.0f ? sqrtf((var_pos + var_neg) / n_eff) / mean : 0.0f;
    p->d = mean > 0.0f ? (p->i_p_pos - p->i_p_neg) / mean : 0.0f;
    p->margin = fabsf(p->d) / fs_maxf(p->cfg.d_min, 3.0f * sigma_d);
    p->attempts += 1;
    p->moved = p->cfg.w_max > 0.0f && p->w_peak > p->cfg.w_max;
    if (p->moved) {
        p->margin = 0.0f;
        p->stage = FS_POLARITY_UNDETERMINED;
    } else if (p->margin >= 1.0f) {
        p->flip = p->d < 0.0f;
        p->stage = FS_POLARITY_DONE;
    } else if (p->i_now < p->cfg.i_pulse_max) {
        p->i_now = fs_minf(1.5f * p->i_now, p->cfg.i_pulse_max);
        polarity_pulses(p);
    } else {
        p->stage = FS_POLARITY_UNDETERMINED;
    }
}

/* Accumulates I_p over the pulse's averaging window (its last n_avg
 * samples) by carrier periods: each period's mean, relative to the window's
 * first sample (float sums of squares of differences keep their precision). */
static void polarity_sample(fs_polarity *p, float i_p, float *ref, float *sum, float *sq)
{
    const int k0 = p->n_pulse - p->n_avg;
    if (p->k < k0) { return; }
    if (p->k == k0) { *ref = i_p; }
    p->acc += i_p - *ref;
    if ((p->k - k0 + 1) % p->n_per == 0) {
        const float x = p->acc / (float)p->n_per;
        *sum += x;
        *sq += x * x;
        p->acc = 0.0f;
    }
}

float fs_polarity_step(fs_polarity *p, float i_p, float w)
{
    /* the mean estimated speed over each half pulse against the half before
     * (means: the estimate's noise averages out, a spin-up does not) */
    if (p->stage == (int)FS_POLARITY_POS || p->stage == (int)FS_POLARITY_NEG) {
        if (p->stage == (int)FS_POLARITY_POS && p->k == 0) { p->halves = 0; }
        p->w_sum += w;
        const int half = p->n_pulse / 2;
        if (p->k + 1 == half || p->k + 1 == p->n_pulse) {
            const float mean = p->w_sum / (float)(p->k + 1 == half ? half : p->n_pulse - half);
            if (p->halves > 0) { p->w_peak = fs_maxf(p->w_peak, fabsf(mean - p->w_prev)); }
            p->w_prev = mean;
            p->halves += 1;
            p->w_sum = 0.0f;
        }
    }
    switch (p->stage) {
    case FS_POLARITY_LOCK:
        if (++p->k >= p->n_lock) {
            polarity_pulses(p);
            return p->i_now;
        }
        return 0.0f;
    case FS_POLARITY_POS:
        polarity_sample(p, i_p, &p->ref_pos, &p->sum_pos, &p->sq_pos);
        if (++p->k >= p->n_pulse) {
            p->i_p_pos = p->ref_pos + p->sum_pos / (float)polarity_periods(p);
            p->stage = FS_POLARITY_NEG;
            p->k = 0;
            return -p->i_now;
        }
        return p->i_now;
    case FS_POLARITY_NEG:
        polarity_sample(p, i_p, &p->ref_neg, &p->sum_neg, &p->sq_neg);
        if (++p->k >= p->n_pulse) {
            p->i_p_neg = p->ref_neg + p->sum_neg / (float)polarity_periods(p);
            polarity_decide(p);
            return p->stage == (int)FS_POLARITY_POS ? p->i_now : 0.0f;
        }
        return -p->i_now;
    default:
        return 0.0f;
    }
}
