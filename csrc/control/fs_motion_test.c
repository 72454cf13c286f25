#include "fs_motion_test.h"
#include "fs_math.h"

FS_COLD fs_status fs_motion_test_init(fs_motion_test *m, const fs_motion_test_config *cfg)
{
    fs_status ret;
    if (!m || !cfg) { ret = FS_ERR_NULL; }
    else if (!fs_pos(cfg->Ts)) { ret = FS_ERR_TS; }
    else if (!fs_pos(cfg->i_push)) { ret = FS_ERR_I_MAX; }
    else if (!fs_fin(cfg->i_push_max) || !((cfg->i_push_max == 0.0f) || (cfg->i_push_max >= cfg->i_push))) { ret = FS_ERR_I_MAX; }
    else {
        /* the step counts must stay ints: below 1e9 */
        const float t_all = cfg->t_lock + (2.0f * cfg->t_push) + cfg->t_settle;
        if (!(cfg->t_lock >= (8.0f * cfg->Ts)) || !(cfg->t_push >= cfg->Ts) || !(cfg->t_settle >= cfg->Ts) || !(t_all < 1e3f)
            || !((t_all / cfg->Ts) < 1e9f)) {
            ret = FS_ERR_PARAM;
        }
        else if (!((cfg->theta_dec > 0.0f) && (cfg->theta_dec < (0.5f * FS_PI)))) { ret = FS_ERR_PARAM; }
        else if (!((cfg->theta_max == 0.0f) || ((cfg->theta_max >= cfg->theta_dec) && (cfg->theta_max < (0.5f * FS_PI))))) { ret = FS_ERR_PARAM; }
        else {
            m->cfg = *cfg;
            if (m->cfg.i_push_max == 0.0f) { m->cfg.i_push_max = cfg->i_push; }
            if (m->cfg.theta_max == 0.0f) { m->cfg.theta_max = fs_minf(4.0f * cfg->theta_dec, 0.49f * FS_PI); }
            const float n_lock_f = (cfg->t_lock / cfg->Ts) + 0.5f;
            m->n_lock = (int)n_lock_f;
            const float n_push_f = (cfg->t_push / cfg->Ts) + 0.5f;
            m->n_push = (int)n_push_f;
            const float n_settle_f = (cfg->t_settle / cfg->Ts) + 0.5f;
            m->n_settle = (int)n_settle_f;
            fs_motion_test_reset(m);
            ret = FS_OK;
        }
    }
    return ret;
}

/* A window starts: its first value, and its spread and sums cleared */
static void window_clear(fs_motion_test *m, float theta_half)
{
    m->theta_half = theta_half;
    m->lo = 0.0f;
    m->hi = 0.0f;
    m->sx = 0.0f;
    m->sy = 0.0f;
    m->sxx = 0.0f;
    m->sxy = 0.0f;
    m->n_win = 0;
}

void fs_motion_test_reset(fs_motion_test *m)
{
    m->stage = FS_MOTION_LOCK;
    m->k = 0;
    m->attempts = 0;
    m->locks = 0;
    m->settles = 0;
    m->i_now = m->cfg.i_push;
    window_clear(m, 0.0f);
    m->threshold = m->cfg.theta_dec;
    m->theta_ref = 0.0f;
    m->turn = 0.0f;
    m->moved = false;
    m->flip = false;
}

/* The estimate over a window: its spread about its first value and the
 * sums of a least-squares line through it (x: steps from the window's
 * start, y: the estimate less its first value), which gives its mean speed
 * without the noise of two end points. */
static void motion_window(fs_motion_test *m, float theta, int j)
{
    if (j == 0) {
        window_clear(m, theta);
    }
    const float y = fs_wrap_pi(theta - m->theta_half);
    const float x = (float)j;
    m->lo = fs_minf(m->lo, y);
    m->hi = fs_maxf(m->hi, y);
    m->sx += x;
    m->sy += y;
    m->sxx += x * x;
    m->sxy += x * y;
    m->n_win += 1;
}

/* The window's mean speed, el. rad/s (its line's slope). */
static float motion_window_speed(const fs_motion_test *m)
{
    const float n = (float)m->n_win;
    const float den = (n * m->sxx) - (m->sx * m->sx);
    return (den > 0.0f) ? (((n * m->sxy) - (m->sx * m->sy)) / den / m->cfg.Ts) : 0.0f;
}

/* Whether the rotor turns on its own at the window's speed: by `share` of
 * the threshold within the horizon, s. */
static bool motion_turning(const fs_motion_test *m, float horizon, float share)
{
    return (fabsf(motion_window_speed(m)) * horizon) > (share * m->threshold);
}

/* The doublet's current at step k of it: one period of a sine over 2 n_push
 * steps, sampled at the steps' middles. */
static float motion_doublet(const fs_motion_test *m)
{
    return m->i_now * fs_sinf(FS_PI * ((float)m->k + 0.5f) / (float)m->n_push);
}

/* The lock's end: the threshold from the estimate's spread, the refusals of
 * a noisy estimate and of a rotor already turning (once more, then for
 * good); else the first doublet. */
static float motion_lock_end(fs_motion_test *m, float theta)
{
    float ret;
    m->threshold = fs_maxf(m->cfg.theta_dec, 2.0f * (m->hi - m->lo));
    m->moved = motion_turning(m, (2.0f * m->cfg.t_push) + m->cfg.t_settle, 1.0f);   /* all of it within the test */
    m->k = 0;
    if (m->moved || (m->threshold > m->cfg.theta_max)) {
        m->locks += 1;
        if (m->locks >= FS_MOTION_LOCKS) { m->stage = FS_MOTION_UNDETERMINED; }
        ret = 0.0f;
    }
    else {
        m->stage = FS_MOTION_PUSH;
        m->theta_ref = theta;
        ret = motion_doublet(m);
    }
    return ret;
}

/* The turn read after the doublet: the decision, another doublet, or the
 * refusal. An estimate still turning by the threshold over the settling's
 * second half (an observer still catching up, or a load moving the rotor)
 * is waited for, FS_MOTION_LOCKS settlings in all, then refused. */
static float motion_read(fs_motion_test *m, float theta)
{
    float ret;
    m->turn = fs_wrap_pi(theta - m->theta_ref);
    m->k = 0;
    m->moved = motion_turning(m, (float)m->n_win * m->cfg.Ts, 1.0f);
    if (m->moved) {   /* beyond the largest threshold already: something else turns the rotor */
        m->settles += 1;
        if ((m->settles >= FS_MOTION_LOCKS) || fabsf(m->turn) > m->cfg.theta_max) { m->stage = FS_MOTION_UNDETERMINED; }
        ret = 0.0f;
    }
    else {
        m->settles = 0;
        m->attempts += 1;
        if (fabsf(m->turn) >= m->threshold) {
            m->flip = m->turn < 0.0f;
            m->stage = FS_MOTION_DONE;
            ret = 0.0f;
        }
        else if (m->i_now < m->cfg.i_push_max) {
            m->i_now = fs_minf(1.5f * m->i_now, m->cfg.i_push_max);
            m->stage = FS_MOTION_PUSH;
            ret = motion_doublet(m);
        }
        else {
            m->stage = FS_MOTION_UNDETERMINED;
            ret = 0.0f;
        }
    }
    return ret;
}

float fs_motion_test_step(fs_motion_test *m, float theta)
{
    float ret = 0.0f;   /* the q-current reference: none but in the push and the stages' last steps */
    switch (m->stage) {
    case FS_MOTION_LOCK: {
        const int half = m->n_lock / 2;
        if (m->k >= half) { motion_window(m, theta, m->k - half); }
        ++m->k;
        if (m->k >= m->n_lock) { ret = motion_lock_end(m, theta); }
        break;
    }
    case FS_MOTION_PUSH:
        ++m->k;
        if (m->k >= (2 * m->n_push)) {
            m->stage = FS_MOTION_SETTLE;
            m->k = 0;
        } else {
            ret = motion_doublet(m);
        }
        break;
    case FS_MOTION_SETTLE: {
        const int half = m->n_settle / 2;   /* the rotor's speed over the settling's second half */
        if (m->k >= half) { motion_window(m, theta, m->k - half); }
        ++m->k;
        if (m->k >= m->n_settle) { ret = motion_read(m, theta); }
        break;
    }
    default:
        break;
    }
    return ret;
}
