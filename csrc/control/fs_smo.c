#include "fs_smo.h"
#include "fs_math.h"

/* The tracking form's bandwidths (fs_smo.h, change 3) for the speed the
 * EMF's magnitude gives: the tracker at FS_SMO_BW_PER_W of it, within
 * [that at w_sched_min, bw_pll], re-designed (fs_motion_obs_init, its state
 * kept) when it moves by more than a tenth; the filter's cutoff is set in
 * the step from it. The re-design is rare and out of line, the check that
 * skips it inline in the step: as one function, its call, frame and base
 * address cost 11 instructions a step on a Cortex-M4F (bench/pil.py). */
FS_OUT_OF_LINE FS_COLD void smo_redesign(fs_smo *o, float want)
{
    const float theta = o->mo.theta_hat, w_hat = o->mo.w_hat, T_d = o->mo.T_d_hat;
    fs_motion_obs_config mc = o->mo.cfg;
    mc.bandwidth = want;
    (void)fs_motion_obs_init(&o->mo, &mc);   /* J, B, p checked in fs_smo_init; 0 < want <= bw_pll */
    fs_motion_obs_reset(&o->mo, theta, w_hat);
    o->mo.T_d_hat = T_d;
    o->n_settle = fs_ceil_int(4.0f / (want * o->cfg.Ts));
}

static inline void smo_schedule(fs_smo *o)
{
    /* the EMF's speed: over the active flux at the current (psi_x), not
     * the magnet's alone, which under load on a salient machine reads the
     * speed several times too high (the 2004 Prius MG2 at 200 N m: psi_x
     * 0.51 Wb, psi_f 0.16) and schedules the tracker beyond its filter */
    const float w_emf = o->e_raw / o->psi_x;
    const float want = fs_minf(FS_SMO_BW_PER_W * fs_maxf(w_emf, o->w_sched_min), o->cfg.bw_pll);
    const float now = o->mo.cfg.bandwidth;
    if (!(fabsf(want - now) <= 0.1f * now)) { smo_redesign(o, want); }   /* a NaN re-designs, as before */
}

FS_COLD fs_status fs_smo_init(fs_smo *o, const fs_smo_config *cfg)
{
    if (!o || !cfg) { return FS_ERR_NULL; }
    if (!fs_pos(cfg->Ts)) { return FS_ERR_TS; }
    if (!fs_nonneg(cfg->R_s)) { return FS_ERR_RS; }
    if (!fs_pos(cfg->L_d)) { return FS_ERR_LD; }
    if (!fs_pos(cfg->L_q)) { return FS_ERR_LQ; }
    if (!fs_nonneg(cfg->psi_f)) { return FS_ERR_PSI_F; }
    if (!fs_pos(cfg->w_e_max) || !fs_pos(cfg->i_max) || !(cfg->margin >= 1.0f) || !fs_fin(cfg->margin)) {
        return FS_ERR_LIMIT;
    }
    if (!fs_nonneg(cfg->k) || !fs_nonneg(cfg->delta) || !fs_nonneg(cfg->w_valid)) { return FS_ERR_PARAM; }
    if (cfg->lag != (int)FS_SMO_LAG_EXACT && cfg->lag != (int)FS_SMO_LAG_PAPER) { return FS_ERR_MODE; }
    if (cfg->form != (int)FS_SMO_FORM_PAPER && cfg->form != (int)FS_SMO_FORM_TRACKING) { return FS_ERR_MODE; }
    o->cfg = *cfg;
    /* eq. (18): k > max(|e_alpha|, |e_beta|) / 2, with the extended EMF
     * E_ex = w psi_f + (L_d - L_q) w i_d at most w_max (psi_f + |L_d - L_q| i_max) */
    float E_max = cfg->w_e_max * (cfg->psi_f + fabsf(cfg->L_d - cfg->L_q) * cfg->i_max);
    o->k_bound = 0.5f * E_max;
    if (cfg->k > 0.0f && cfg->k <= o->k_bound) { return FS_ERR_SMO_GAIN; }
    o->k = cfg->k > 0.0f ? cfg->k : cfg->margin * o->k_bound;
    o->delta = fs_maxf(cfg->delta, o->k * cfg->Ts / cfg->L_d);
    /* a designed gain of 0 (no EMF: psi_f = 0, L_d = L_q) or beyond the float range */
    if (!fs_pos(o->k) || !fs_pos(o->delta)) { return FS_ERR_SMO_GAIN; }
    o->i_hat_max = 16.0f * cfg->i_max;
    fs_lpf_config lc = {cfg->Ts, cfg->w_c_min};
    fs_status st = fs_lpf_init(&o->lpf, &lc);
    if (st != FS_OK) { return st; }
    fs_pll_config pc = {cfg->Ts, cfg->bw_pll, 1.5f * cfg->w_e_max};
    st = fs_pll_init(&o->pll, &pc);
    if (st != FS_OK) { return st; }
    /* the boundary layer's correction per step, k Ts / (L_d delta) <= 1 */
    o->c_bl = fs_minf(o->k * cfg->Ts / (cfg->L_d * o->delta), 1.0f);
    /* 0.4 w_valid psi_f: the filtered EMF at w_valid (the loop passes
     * 1 / sqrt 5 of it at w_c = w) */
    o->e_valid = 0.4f * cfg->w_valid * cfg->psi_f;
    /* converged: 4 time constants of the tracker without a break */
    o->n_settle = fs_ceil_int(4.0f / (cfg->bw_pll * cfg->Ts));
    o->a_emf = -expm1f(-cfg->bw_pll * cfg->Ts);
    if (cfg->form == (int)FS_SMO_FORM_TRACKING) {
        if (cfg->phases != 3 && cfg->phases != 5) { return FS_ERR_PARAM; }
        if (!fs_pos(cfg->psi_f)) { return FS_ERR_PSI_F; }   /* the schedule's speed is the EMF over psi_f */
        /* checked at the top bandwidth: the schedule only lowers it */
        fs_motion_obs_config mc = {cfg->Ts, cfg->J, cfg->B, cfg->pole_pairs, cfg->bw_pll};
        st = fs_motion_obs_init(&o->mo, &mc);
        if (st != FS_OK) { return st; }
        o->k_T = 0.5f * (float)cfg->phases * (float)cfg->pole_pairs;
        o->w_sched_min = fs_maxf(cfg->w_valid, cfg->w_c_min);
        /* the filtered EMF at w_valid behind the filter at FS_SMO_WC_PER_BW
         * times the tracker's bandwidth there: r / sqrt(4 r^2 + 1) of it */
        const float r = FS_SMO_WC_PER_BW * FS_SMO_BW_PER_W;
        o->e_valid = r / sqrtf(4.0f * r * r + 1.0f) * cfg->w_valid * cfg->psi_f;
    }
    o->L_q_run = cfg->L_q;   /* the model until a map's values come (fs_smo_set_model; a reset keeps them) */
    o->psi_run = cfg->psi_f;
    o->map = false;
    fs_smo_reset(o, 0.0f, 0.0f);
    return FS_OK;
}

FS_COLD void fs_smo_reset(fs_smo *o, float theta, float w)
{
    o->i_hat.alpha = o->i_hat.beta = 0.0f;
    o->z = o->i_hat;
    fs_lpf_reset(&o->lpf);
    fs_pll_reset(&o->pll, theta, w);
    o->e_raw = fabsf(w) * o->cfg.psi_f;
    o->psi_x = o->cfg.psi_f;   /* at no current */
    o->w_emf = o->w_emf_lp = w;
    o->gen = false;
    if (o->cfg.form == (int)FS_SMO_FORM_TRACKING) {
        fs_motion_obs_reset(&o->mo, theta, w);
        smo_schedule(o);
    }
    o->i_prev = o->i_hat;
    o->have_prev = false;
    o->k_settled = 0;
    o->converged = false;
    o->theta = theta;
    o->w = w;
    o->dir = w < 0.0f ? -1.0f : 1.0f;
    o->valid = false;
    o->n_cross = 0;
    o->n_hold = 0;
    o->T_hold = 0.0f;
    o->w_hold = 0.0f;
    o->th_hold = 0.0f;
    o->t_hold = 0.0f;
    o->r_i = o->eps = o->e_mag = 0.0f;
}

void fs_smo_follow(fs_smo *o, float theta, float w, float T_d)
{
    /* only while its own EMF says the rotor is below w_valid: a caller's
     * estimate that has slipped (the injection's, thrown out of its range)
     * would otherwise hold the observer on itself, never valid, never
     * converged, and the two could not be told apart. The EMF over the
     * active flux at the current (psi_x), not the magnet's alone: under
     * load on a salient machine the EMF of w_valid is several times
     * w_valid psi_f (the 2004 Prius MG2 at 200 N m: psi_x 0.51 Wb, psi_f
     * 0.16), and the hand-over ended at a third of w_valid */
    if ((o->cfg.form != (int)FS_SMO_FORM_TRACKING) || o->valid || (o->e_raw >= (o->cfg.w_valid * o->psi_x))) { return; }
    fs_motion_obs_reset(&o->mo, theta, w);
    o->mo.T_d_hat = T_d;
    o->theta = o->mo.theta_hat;
    o->w = o->mo.w_hat;
    o->k_settled = 0;
    o->converged = false;
}

void fs_smo_set_model(fs_smo *o, float L_q, float psi_a)
{
    o->L_q_run = L_q;
    o->psi_run = fs_maxf(psi_a, 0.5f * o->cfg.psi_f);   /* as smo_psi_x: a large positive i_d */
    o->map = true;
}

void fs_smo_speed(fs_smo *o, float k)
{
    if ((o->cfg.form == (int)FS_SMO_FORM_TRACKING) && o->valid && (o->n_hold == 0) && (o->n_cross == 0) && !o->converged && (k > 0.0f)) {
        const float w_o = o->mo.cfg.bandwidth;
        const float kT = k * w_o * o->cfg.Ts;
        const float dw = ((o->dir * o->e_raw) / o->psi_x) - o->mo.w_hat;
        o->mo.w_hat += (2.0f * kT) * dw;
        o->mo.T_d_hat += ((kT * w_o) * dw) / o->mo.k_u;
        o->w = o->mo.w_hat;
    }
}

void fs_smo_hold(fs_smo *o, int n)
{
    if (o->valid && (n > 0)) {   /* read by the tracking form only */
        o->n_hold = n;
        o->t_hold = ((float)n) * o->cfg.Ts;
        o->w_hold = 0.0f;
        o->th_hold = 0.0f;
    }
}

void fs_smo_set_dir(fs_smo *o, float w)
{
    if (w > 0.0f) { o->dir = 1.0f; }
    else if (w < 0.0f) { o->dir = -1.0f; }
    else { /* no direction at zero (or NaN): the last one kept */ }
}

static float sat(float x, float delta)  /* eq. (6) */
{
    return fs_clamp_sym(x / delta, 1.0f);
}

/* The tracking form's angle from the filtered EMF, at the sampling instant
 * (fs_smo.h, change 2), for the speed w the model used and the filter's
 * gain g; and 1 / |H| there, the period's EMF over the filtered one
 * (change 4). */
static float smo_emf_angle(const fs_smo *o, fs_ab e, float w, float g, float *h_inv)
{
    const float Ts = o->cfg.Ts;
    /* the EMF's direction turned by -pi/2 (by +pi/2 running backwards) */
    const float xr = o->dir > 0.0f ? e.beta : -e.beta, xi = o->dir > 0.0f ? -e.alpha : e.alpha;
    const float c = o->c_bl;
    const float _Complex z = fs_cis_small(w * Ts);   /* a step's turn: small */
    const float zr = fs_cre(z), zi = fs_cim(z);
    /* den = (z - 1 + g)(z - 1 + c) + g c z */
    const float ar = zr - 1.0f + g, br = zr - 1.0f + c;
    const float dr = ar * br - zi * zi + g * c * zr;
    const float di = ar * zi + zi * br + g * c * zi;
    *h_inv = sqrtf(dr * dr + di * di) / (g * c);
    /* arg(x) + arg(den) = arg(x den): one arctangent instead of two */
    return fs_wrap_pi(fs_atan2f(xr * di + xi * dr, xr * dr - xi * di) - 1.5f * w * Ts);
}

/* The flux the EMF's magnitude is the speed times: psi_f + (L_d - L_q) i_d
 * (the extended EMF at constant current), at least psi_f / 2 (a machine
 * with L_d > L_q and a large positive i_d). */
static float smo_psi_x(const fs_smo_config *c, float i_d)
{
    return fs_maxf(c->psi_f + (c->L_d - c->L_q) * i_d, 0.5f * c->psi_f);
}

static void smo_settle(fs_smo *o)
{
    /* the EMF's own speed, signed with the direction the angle assumes,
     * against the estimate (fs_smo.h, convergence) */
    const float tol = FS_SMO_AGREE * fs_maxf(fabsf(o->w), o->cfg.w_valid);
    const float e = o->cfg.form == (int)FS_SMO_FORM_TRACKING ? o->w_emf_lp * o->psi_x : o->dir * o->e_raw;
    const bool agree = fabsf(e - o->w * o->psi_x) <= tol * o->psi_x;
    const bool in = agree && o->r_i <= 1.0f && fabsf(o->eps) < 0.0872f;   /* sin 5 deg */
    o->k_settled = in ? o->k_settled + 1 : 0;
    if (o->k_settled >= o->n_settle) {
        o->k_settled = o->n_settle;
        o->converged = true;
    } else if (!in) {
        o->converged = false;
    } else {
        /* agreeing, not yet for n_settle steps: converged as it was */
    }
}

/* (L_inc - L_d) di_dq/dt (fs_smo.h, saturation's transient): di_dq/dt is
 * the period's change of the measured current (the i0 -> i that eq. (4)
 * integrates over, fs_smo_step) less the frame's turn,
 * d/dt (P(-th) i_ab) = P(-th) di_ab/dt - w J i_dq, in the tracker's frame
 * at the period's middle with its speed, as fs_smo_step's torque. Apart
 * from the step, which stays as it was without a map (B-PIL's budget: four
 * more floats here pushed the drive's hot members past 1 KB, +7
 * instructions a step). */
fs_ab fs_smo_transient(const fs_smo *o, fs_ab i, const fs_fluxmap_point *p)
{
    const fs_smo_config *c = &o->cfg;
    if (c->form != (int)FS_SMO_FORM_TRACKING) { return (fs_ab){0.0f, 0.0f}; }
    const float Ts = c->Ts, k = 1.0f / Ts, w = o->mo.w_hat;
    const fs_ab i0 = o->have_prev ? o->i_prev : i;
    const float th = o->mo.theta_hat + 0.5f * Ts * w, cm = fs_cosf(th), sm = fs_sinf(th);
    const fs_dq i_dq = fs_park((fs_ab){0.5f * (i0.alpha + i.alpha), 0.5f * (i0.beta + i.beta)}, cm, sm);
    const fs_dq dp = fs_park((fs_ab){k * (i.alpha - i0.alpha), k * (i.beta - i0.beta)}, cm, sm);
    const fs_dq di = {dp.d + w * i_dq.q, dp.q - w * i_dq.d};
    /* the map's L_inc less the model's L_d on both axes; its cross terms whole */
    const float dL_dd = p->L_dd - c->L_d, dL_qq = p->L_qq - c->L_d;
    const fs_dq v = {dL_dd * di.d + p->L_dq * di.q, p->L_qd * di.d + dL_qq * di.q};
    return fs_inv_park(v, cm, sm);
}

/* A zero crossing of the tracking form (fs_smo.h): the EMF fades through
 * the band below w_valid and turns about at zero, so that the angle it
 * gives is no angle there. The tracker carries the estimate on its motion
 * model alone, the current's torque T and the load T_d it learnt while
 * valid, until the estimate is through the band and the EMF's filter,
 * turned about at zero, has settled at its floor cutoff; at most for twice
 * the time the model's acceleration needs through the band (0.8 w_valid
 * one way, w_valid the other) and the filter's settling after. */
FS_OUT_OF_LINE FS_COLD void smo_cross_enter(fs_smo *o, float T)
{
    const fs_smo_config *c = &o->cfg;
    const float a = o->mo.k_u * (T + o->mo.T_d_hat);
    const float t_x = (3.6f * c->w_valid) / fabsf(a);
    /* only where the model turns the speed through zero, and not a stop
     * near zero speed (FS_SMO_CROSS_MAX), where the torque fades as before */
    if (((a * o->mo.w_hat) < 0.0f) && (t_x < FS_SMO_CROSS_MAX)) {
        const float n_filter = 3.0f / (FS_SMO_WC_PER_BW * o->mo.cfg.bandwidth * c->Ts);
        const float n_x = t_x / c->Ts;
        o->n_settle_dir = 1 + (int)n_filter;
        o->n_cross = (int)n_x + o->n_settle_dir;
        o->n_dir = 0;
        o->n_emf = 0;
    }
}

FS_OUT_OF_LINE FS_COLD void smo_cross_step(fs_smo *o, float T)
{
    const fs_smo_config *c = &o->cfg;
    (void)fs_motion_obs_predict(&o->mo, T);
    const float w = o->mo.w_hat;
    bool contradicted = false;
    if ((o->n_dir == 0) && ((w * o->dir) < 0.0f)) {
        o->n_dir = o->n_settle_dir;   /* through zero: the filter turns about */
    } else if (o->n_dir > 1) {
        --o->n_dir;
    } else if (o->n_dir == 0) {
        /* before zero, an EMF that stays at w_valid's beyond its
         * low-pass's settling says the rotor is not in the band: the
         * estimate fell below it on its own (a disturbance), not with the
         * rotor; the crossing ends and the EMF is read again */
        o->n_emf = (o->e_raw >= (c->w_valid * o->psi_x)) ? (o->n_emf + 1) : 0;
        contradicted = (((float)o->n_emf * c->bw_pll) * c->Ts) > 3.0f;
    } else {
        /* past zero with the filter settled: through once beyond w_valid */
    }
    const bool through = (o->n_dir == 1) && (fabsf(w) >= c->w_valid);
    o->n_cross = (through || contradicted) ? 0 : (o->n_cross - 1);
}

/* A step on the model alone: the caller's hold (fs_smo_hold), else a
 * zero crossing's */
FS_OUT_OF_LINE FS_COLD bool smo_model_step(fs_smo *o, float T)
{
    bool stepped = true;
    if (o->n_hold > 0) {
        /* the angle and speed the torque's change since the hold began has
         * given the model: past FS_SMO_HOLD_DRIFT by the hold's end, or the
         * speed past it over a hold's length, the hold ends and the EMF
         * corrects again, this step on (fs_smo.h) */
        const float Ts = o->cfg.Ts;
        o->w_hold += o->mo.k_u * (T - o->T_hold) * Ts;
        o->th_hold += o->w_hold * Ts;
        if ((fabsf(o->th_hold + (o->w_hold * (float)o->n_hold * Ts)) > FS_SMO_HOLD_DRIFT) || ((fabsf(o->w_hold) * o->t_hold) > FS_SMO_HOLD_DRIFT)) {
            o->n_hold = 0;
            stepped = false;
        } else {
            --o->n_hold;
            (void)fs_motion_obs_predict(&o->mo, T);
        }
    } else {
        smo_cross_step(o, T);
    }
    return stepped;
}

float fs_smo_step(fs_smo *o, fs_ab i, fs_ab u)
{
    const fs_smo_config *c = &o->cfg;
    const bool track = c->form == (int)FS_SMO_FORM_TRACKING;
    float T_step = 0.0f;   /* the tracking form's torque of the period, for a zero crossing's start (below) */
    const fs_ab e_hat = o->lpf.y;
    const float w = track ? o->mo.w_hat : o->pll.w;
    /* eq. (4) over the period that just ended, with the voltage that acted in
     * it; the tracking form takes the measured currents' mean in the
     * resistive and cross-coupling terms (fs_smo.h, change 1) and, where
     * the tracker's speed would turn the angle against the error (G > 0),
     * the speed of the EMF's magnitude in the cross-coupling (change 4) */
    const float wdL = (track && o->gen ? o->w_emf : w) * (c->L_d - o->L_q_run);
    fs_ab i_m = o->i_hat;
    if (track) {
        const fs_ab i0 = o->have_prev ? o->i_prev : i;
        i_m.alpha = 0.5f * (i0.alpha + i.alpha);
        i_m.beta = 0.5f * (i0.beta + i.beta);
    }
    float di_a = (-c->R_s * i_m.alpha - wdL * i_m.beta + u.alpha - e_hat.alpha - o->z.alpha) / c->L_d;
    float di_b = (wdL * i_m.alpha - c->R_s * i_m.beta + u.beta - e_hat.beta - o->z.beta) / c->L_d;
    /* Held within 16 i_max (it tracks currents of a few i_max): the forward
     * Euler step grows without bound when R_s Ts / L_d or the rotation
     * w Ts |L_d - L_q| / L_d comes near 1, faster than the bounded
     * switching term pulls it back. */
    const float lim = o->i_hat_max;
    o->i_hat.alpha = fs_clamp_sym(o->i_hat.alpha + c->Ts * di_a, lim);
    o->i_hat.beta = fs_clamp_sym(o->i_hat.beta + c->Ts * di_b, lim);
    /* eqs. (5)-(7): switching function on the current error */
    const float e_a = o->i_hat.alpha - i.alpha, e_b = o->i_hat.beta - i.beta;
    const fs_ab z_prev = o->z;
    o->z.alpha = o->k * sat(e_a, o->delta);
    o->z.beta = o->k * sat(e_b, o->delta);
    o->r_i = fs_maxf(fabsf(e_a), fabsf(e_b)) / o->delta;
    /* Fig. 1: adaptive low-pass filter, cutoff at the estimated speed; the
     * tracking form's at least FS_SMO_WC_PER_BW times its tracker's
     * bandwidth (fs_smo.h, change 3) */
    const float w_c = track ? fs_maxf(fabsf(w), FS_SMO_WC_PER_BW * o->mo.cfg.bandwidth) : w;
    const float g_c = fs_lpf_gain(&o->lpf, w_c);   /* the filter's, at its floored cutoff */
    fs_ab e = fs_lpf_step_gain(&o->lpf, o->z, g_c);
    /* the period's EMF as the model sees it, from the observer's own
     * recursion inside the boundary layer, z_n = z_{n-1} +
     * c (e_n - e_hat_{n-1} - z_{n-1}): its magnitude sets the schedule and
     * checks the speed (`converged`). Outside it (a current step the model
     * did not predict, z saturated) the recursion does not hold: the
     * magnitude is kept. */
    if (o->r_i <= 1.0f) {
        const float en_a = e_hat.alpha + z_prev.alpha + (o->z.alpha - z_prev.alpha) / o->c_bl;
        const float en_b = e_hat.beta + z_prev.beta + (o->z.beta - z_prev.beta) / o->c_bl;
        o->e_raw += o->a_emf * (sqrtf(en_a * en_a + en_b * en_b) - o->e_raw);
    }
    if (track) {
        const float mag = sqrtf(e.alpha * e.alpha + e.beta * e.beta);
        /* no angle without an EMF: the correction and the torque fade below e_valid */
        const float kappa = o->e_valid > 0.0f ? fs_minf(mag / o->e_valid, 1.0f) : 1.0f;
        const float th_prev = o->mo.theta_hat;
        float err = 0.0f, h_inv = 0.0f;
        if (mag > 1e-6f) { err = fs_wrap_pi(smo_emf_angle(o, e, w, g_c, &h_inv) - th_prev); }
        /* the torque of the period: mean current in the frame at its middle */
        const float th_mid = th_prev + 0.5f * c->Ts * w;
        const fs_dq i_dq = fs_park(i_m, fs_cosf(th_mid), fs_sinf(th_mid));
        o->psi_x = o->map ? o->psi_run : smo_psi_x(c, i_dq.d);
        const float T = o->k_T * o->psi_x * i_dq.q;
        /* change 4: the EMF's speed for the next step's model, and whether
         * it is needed there (G = (L_d - L_q) i_q / (w psi_f) > 0) */
        o->w_emf = o->dir * mag * h_inv / o->psi_x;
        o->gen = (c->L_d - o->L_q_run) * i_dq.q * w > 0.0f;
        /* against the prediction, as the PLL's, low-passed at the tracker's
         * bandwidth: the angle error it is working off, not one sample's
         * (the injection's fade-in steps the fundamental current) */
        const float a_eps = 1.0f - o->mo.z_o;
        const float _Complex ee = fs_cis_small(fs_wrap_pi(err - c->Ts * w));   /* small once converged */
        o->eps += a_eps * (fs_cim(ee) - o->eps);
        o->w_emf_lp += a_eps * (o->w_emf - o->w_emf_lp);
        o->e_mag = mag;
        /* the model's net torque T + T_d fades with the EMF as the
         * correction does, and the current's torque counts only in a frame
         * the EMF has confirmed: at standstill neither a current in an
         * unknown frame nor a load learnt at speed (T_d held) accelerates
         * the estimate */
        T_step = T;
        /* a hold or a zero crossing, on the model alone (header; rare, out of line) */
        bool modelled = false;
        if ((o->n_hold > 0) || (o->n_cross > 0)) {
            modelled = smo_model_step(o, T);
        }
        if (!modelled) {
            const float T_net = o->valid ? kappa * T - (1.0f - kappa) * o->mo.T_d_hat : -o->mo.T_d_hat;
            (void)fs_motion_obs_step(&o->mo, kappa * err, T_net);
            o->T_hold = T;
            /* Becoming valid (below, on this speed), the model's acceleration,
             * nil until now, stays continuous: T_d starts at -T and learns the
             * rest. Whatever T_d held (a load from before, or none) counted in
             * full at once: with the encoder's loops at 150 rpm under 3 N m and
             * no load learnt, the estimate ran to 475 rpm, 24 el.deg off. */
            if (!o->valid && fabsf(o->mo.w_hat) >= c->w_valid) { o->mo.T_d_hat = -T; }
        }
        smo_schedule(o);
        o->w = o->mo.w_hat;
        o->theta = o->mo.theta_hat;
        /* the tracker carries its speed through zero on its motion model
         * (torque, load, inertia): the EMF's direction is that speed's sign.
         * With the PLL's hysteresis (below) the EMF was read pi off from the
         * zero crossing to w_valid: 34.6 el.deg on the grin hub motor reversed
         * through zero by its load (11.9 with the sign) */
        if (!c->dir_external && o->w != 0.0f) { o->dir = o->w < 0.0f ? -1.0f : 1.0f; }
        o->i_prev = i;
        o->have_prev = true;
    } else {
        /* eq. (12): normalized PLL error, sin(theta - theta_pll). The EMF turns
         * with the speed's sign: without the direction the error would be
         * -sin(theta - theta_pll) below zero speed and the PLL would lock pi off
         * (the paper runs one way only). The direction changes only when the
         * PLL's speed passes w_valid the other way: locked pi off, the PLL turns
         * the wrong way, passes it, and the flipped error brings it back. */
        float mag = sqrtf(e.alpha * e.alpha + e.beta * e.beta);
        float eps = 0.0f;
        const float cth = fs_cosf(o->pll.theta), sth = fs_sinf(o->pll.theta);
        if (mag > 1e-6f) {
            eps = (-e.alpha * cth - e.beta * sth) / mag;
            eps *= o->dir;
        }
        o->psi_x = o->map ? o->psi_run : smo_psi_x(c, i.alpha * cth + i.beta * sth);   /* for `converged` */
        (void)fs_pll_step(&o->pll, eps);
        o->eps = eps;
        o->e_mag = mag;
        o->w = o->pll.w;
        float w_c_pll = fs_maxf(fabsf(o->w), c->w_c_min);   /* the filter's cutoff at the PLL's speed */
        float lag = (c->lag == (int)FS_SMO_LAG_PAPER) ? fs_signf(o->w) * 0.25f * FS_PI
                                                 : fs_atanf(o->w / (2.0f * w_c_pll));
        /* the PLL now predicts the next mid-period; back half a period to the sample */
        o->theta = fs_wrap_pi(o->pll.theta - 0.5f * c->Ts * o->w + lag);
        if (!c->dir_external) {   /* the direction turns only past w_valid (above) */
            if (o->w > c->w_valid) { o->dir = 1.0f; }
            else if (o->w < -c->w_valid) { o->dir = -1.0f; }
            else { /* within +-w_valid: the direction kept */ }
        }
    }
    float aw = fabsf(o->w);
    if (aw >= c->w_valid) {
        o->valid = true;
    } else if (aw < (0.8f * c->w_valid)) {   /* hysteresis */
        if (o->valid && track && !c->dir_external) {   /* the blend's injection knows the low speeds */
            smo_cross_enter(o, T_step);
        }
        o->valid = false;
    } else {
        /* within the hysteresis: as it was */
    }
    smo_settle(o);
    return o->theta;
}
