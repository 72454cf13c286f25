#include "fs_mapid.h"
#include "fs_math.h"

/* Design values, each with its reason (fs_mapid.h has the method). */
#define D_STEP 0.02f      /* of i_max a sample: the d sweep's slope, so that its crossings are 12 samples apart and its reversal lands within a step of i_max */
#define I_REACH 1.03f     /* of i_max: the d sweep's reversal, so that the grid's +-i_max is crossed within half its 2 % step (the sequence's trip is at 1.1) */
#define I_REACH_POL 0.8f  /* of i_max: the d sweep's amplitude before the polarity is known: +-3/4 read (the asymmetry's), less of a misalignment's kick */
#define D_STEP_MAX 0.08f  /* of i_max a sample: the d sweep's slope at most where the rotor's motion asks for speed (its reversal within 4 %) */
#define D_MIN 0.55f       /* of i_max: the smallest d sweep where a free rotor's motion bounds it (+-i_max/2 read, the polarity's) */
#define I_REACH_Q 1.01f   /* of i_max: the q sweeps' amplitude: the disc's edge read where the d level leaves it */
#define N_Q_MIN 12        /* samples from 0 to a q sweep's amplitude at least: 1.5 a grid step of i_max / 8 at full amplitude */
#define N_Q_MAX 25        /* at most: longer only turns the rotor more and lets the integral drift */
#define N_Q_MAX_LOCKED 100 /* at most on a locked rotor: the voltage's rise to the disc on a large L_q (the Prius-like machine's
                              6.15 mH to 250 A on 500 V at 10 kHz takes 70) */
#define I_ABORT 1.08f     /* of i_max: a q sweep whose current passes this (its L_q well below the zero current's) stops there */
#define N_SETTLE 4.0f     /* loop time constants a level's d current is given (e^-4: the crossings record the d current as it is) */
#define GROWTH 3.0f       /* a d level whose time would grow a misalignment more than this is not swept */
#define GROWTH_EXP 1.7627472f   /* acosh(GROWTH): the d sweep's exponent at that growth */
#define EMF_TURN 0.0175f  /* el. rad/s x (1 / the level's time): the back-EMF at zero current that stops the sweeps, a speed turning
                             the rotor 1 el.deg a level (psi_f known) */
#define U_SWEEP 0.85f     /* of the linear limit: the swept axis' voltage at most, the held axis' loop keeping the rest */

/* The sweeps' turning points, of I_amp (0: the end):
 * 0 -> +a I -> -I -> +I -> -a I -> 0 with a = (sqrt 5 - 1)/2, point-symmetric
 * in time: the torque's impulse is zero, and the rotor's displacement too
 * at this a; its largest swing is 0.46 A t_I^2 (A the angular acceleration
 * at I, t_I the time 0 -> I takes), against 4 A t_I^2 for
 * 0 -> +I -> -I -> +I -> -I -> 0, whose velocity stays on one side of zero
 * (a search over such patterns, issue 35). The sweeps turn where the
 * current passes these (within half a step: fs_mapid.h), at +-U with the
 * drop fed forward, so that the legs up and down take the same time; what
 * is left of the impulse is trimmed after the q sweeps. */
static const float TURN[] = {0.618034f, 1.0f, 1.0f, 0.618034f, 0.0f};
#define SWING 0.46f
#define POL_STEPS 3       /* the d sweep's steps each way at each of +-i_max/2 the polarity needs (a sweep at 2 % a sample has ~12) */
#define POL_MIN 0.03f     /* the d sweep's asymmetry that decides the polarity: 3 % (its noise: 4 crossings' mean of a flux within 0.5 %) */

/* The q sweeps' d levels, as k of k i_max / 4: alternating signs, so that
 * the torque a misalignment makes with the magnet alternates too; +-i_max
 * has no q left in the disc (the d sweep reads it). */
static const int Q_ORDER[] = {0, 1, -1, 2, -2, 3, -3};
#define N_LEVELS ((int)sizeof(Q_ORDER) / (int)sizeof(Q_ORDER[0]))

FS_COLD fs_status fs_mapid_init(fs_mapid *m, const fs_mapid_config *cfg)
{
    fs_status ret;
    if (!m || !cfg) { ret = FS_ERR_NULL; }
    else if (!fs_pos(cfg->Ts)) { ret = FS_ERR_TS; }
    else if ((cfg->delay != 0.0f) && (cfg->delay != 1.0f)) { ret = FS_ERR_PARAM; }
    else if (!fs_pos(cfg->i_max)) { ret = FS_ERR_I_MAX; }
    else if (!fs_pos(cfg->L_d)) { ret = FS_ERR_LD; }
    else if (!fs_pos(cfg->L_q)) { ret = FS_ERR_LQ; }
    else if (!fs_nonneg(cfg->R_s) || !fs_nonneg(cfg->u_e) || (cfg->pole_pairs < 1) || !fs_nonneg(cfg->psi_f) || !fs_nonneg(cfg->J)
        || !fs_nonneg(cfg->motion_max) || !fs_pos(cfg->w_c) || (cfg->d_only & ~1) || (cfg->pol_known & ~1)) {
        ret = FS_ERR_PARAM;
    }
    else {
        m->cfg = *cfg;
        fs_status st = fs_pi_design_init(&m->pi_d, cfg->Ts, cfg->L_d, cfg->R_s, cfg->w_c, 0.0f);
        if (st == FS_OK) { st = fs_pi_design_init(&m->pi_q, cfg->Ts, cfg->L_q, cfg->R_s, cfg->w_c, 0.0f); }
        if (st != FS_OK) { ret = st; }
        else {
            fs_mapid_reset(m);
            ret = FS_OK;
        }
    }
    return ret;
}

static void sums_clear(fs_mapid *m)
{
    for (int t = 0; t < FS_MAPID_NT; ++t) {
        m->s_x[t] = 0.0f;
        m->s_y[t] = 0.0f;
        m->s_i[t] = 0.0f;
        m->s_up[t] = 0.0f;
        m->s_dn[t] = 0.0f;
        m->s_n[t] = 0;
        m->c_up[t] = 0;
        m->c_dn[t] = 0;
    }
}

void fs_mapid_reset(fs_mapid *m)
{
    static const fs_mapid_result none = { 0 };
    m->res = none;
    m->stage = FS_MAPID_DSWEEP;
    m->level = 0;
    m->k = 0;
    m->leg = 0;
    m->rleg = 0;
    fs_pi_reset(&m->pi_d);
    fs_pi_reset(&m->pi_q);
    m->I_d = 0.0f;
    m->I_amp = 0.0f;
    m->U = 0.0f;
    m->n_rise = 0;
    m->n_trim = 0;
    m->restarts = 0;
    m->impulse = 0.0f;
    m->torque_imp = 0.0f;
    m->psi_d = 0.0f;
    m->psi_q = 0.0f;
    m->x_prev = 0.0f;
    m->dx_last = 0.0f;
    m->y_prev = 0.0f;
    m->e_prev_d = 0.0f;
    m->e_prev_q = 0.0f;
    m->u_out[0] = (fs_dq){0.0f, 0.0f};
    m->u_out[1] = (fs_dq){0.0f, 0.0f};
    m->seen = 0u;
    sums_clear(m);
}

/* the held axis' loop, its output within lim */
static float hold(fs_pi *pi, float ref, float meas, float lim)
{
    const float u = fs_pi_output(pi, ref, meas);
    const float ur = fs_clamp_sym(u, lim);
    fs_pi_update(pi, ref, meas, u, ur);
    return ur;
}

/* The torque per A of q current at d current i_d, relative to the magnet's
 * alone: (psi_f + (L_d - L_q) i_d) / psi_f (1 where psi_f is not known). */
static float torque_weight(const fs_mapid_config *c, float i_d)
{
    return (c->psi_f > 0.0f) ? 1.0f + (c->L_d - c->L_q) * i_d / c->psi_f : 1.0f;
}

/* The free rotor's electrical speed, el. rad/s, as its model has it: the
 * torque's impulse since it was last at rest (torque_imp, over 1.5 p psi_f)
 * over J, at the middle of the period that just ended (torque_imp has its
 * last sample, whose q current is i_q at torque weight w); 0 where psi_f or
 * J is not known (a locked rotor). */
static float swing_speed(const fs_mapid *m, float w_iq)
{
    const fs_mapid_config *c = &m->cfg;
    float ret = 0.0f;
    if ((c->psi_f > 0.0f) && (c->J > 0.0f)) {
        const float p = (float)c->pole_pairs;
        ret = (1.5f * p * p * c->psi_f / c->J) * (m->torque_imp - (0.5f * c->Ts * w_iq));
    }
    return ret;
}

/* The flux over the period that just ended: the voltage that acted in it
 * (d periods after it was written) less R_s i and the inverter's error at
 * the mean of its two current samples, and less the speed voltage of the
 * rotor's swing (w psi_q on d, -w psi_d on q: the swing w the model's,
 * swing_speed; psi_d0 the d flux at the sweep's start, psi_q's there 0).
 * Left in, the swing's angle theta adds psi_d theta to the q flux read and
 * -psi_q theta to the d flux: on zoo machine 10 (seed 2026) its 1 el.deg
 * read psi_q up to 2.1 % of psi_f low, against 0.03 % on the rotor locked. */
static void integrate(fs_mapid *m, fs_dq i, fs_dq e, fs_dq i_prev, float psi_d0)
{
    const fs_dq u = (m->cfg.delay > 0.5f) ? m->u_out[1] : m->u_out[0];
    const float Ts = m->cfg.Ts;
    const float R = m->cfg.R_s;
    const float w = swing_speed(m, torque_weight(&m->cfg, i.d) * i.q);
    const float w_psi_q = w * m->psi_q;
    const float w_psi_d = w * (psi_d0 + m->psi_d);
    m->psi_d += Ts * (u.d - (R * 0.5f * (i.d + i_prev.d)) - (0.5f * (e.d + m->e_prev_d)) + w_psi_q);
    m->psi_q += Ts * (u.q - (R * 0.5f * (i.q + i_prev.q)) - (0.5f * (e.q + m->e_prev_q)) - w_psi_d);
}

/* A sweep's sample: the grid values (index t of value (t - n) h) the
 * swept current x passed since the last sample in this leg's direction,
 * each once a leg, read by interpolation; the held current y with them.
 * psi_x0, psi_y0: the fluxes at the last sample (swept, held). */
static void crossings(fs_mapid *m, float x, float y, float psx, float psy, float psx0, float psy0, int n, float h)
{
    const float dx = x - m->x_prev;
    int dir = (m->rleg & 1) ? -1 : 1;
    if ((m->rleg < m->leg) && dx * (float)dir < 0.0f) {   /* the current has turned: the next leg reads */
        m->rleg++;
        m->seen = 0u;
        dir = -dir;
    }
    if (!(dx * (float)dir > 0.0f)) { /* nothing more to do */ }
    else {
        const float mid = 0.5f * (x + m->x_prev);
        for (int t = 0; t <= (2 * n); ++t) {   /* the steps near each value, for its incremental L */
            const int tn = t - n;
            if (fabsf(mid - (float)tn * h) > (0.5f * h)) { continue; }
            if (dir > 0) {
                m->s_up[t] += dx;
                m->c_up[t]++;
            } else {
                m->s_dn[t] += dx;
                m->c_dn[t]++;
            }
        }
        for (int t = 0; t <= (2 * n); ++t) {
            const int tn = t - n;
            const float v = (float)tn * h;
            const bool passed = (dir > 0) ? ((m->x_prev < v) && (x >= v)) : ((m->x_prev > v) && (x <= v));
            if (!passed || ((m->seen & (1u << (unsigned)t)) != 0u)) { continue; }
            const float f = (v - m->x_prev) / dx;
            m->seen |= 1u << (unsigned)t;
            m->s_x[t] += psx0 + (f * (psx - psx0));   /* the swept axis' flux */
            m->s_y[t] += psy0 + (f * (psy - psy0));   /* the held axis' (d in the q sweeps) */
            m->s_i[t] += m->y_prev + (f * (y - m->y_prev));
            m->s_n[t]++;
        }
    }
}

/* The bang-bang voltage on the swept axis, reversed where the current will
 * pass the leg's turning point (turn[leg] I_amp, up on even legs, down on
 * odd ones) within the delay; true when the last leg (turn 0) has brought
 * the current back to 0. */
static bool leg_next(fs_mapid *m, float x, const float *turn)
{
    bool ret;
    const bool up = !(m->leg & 1);
    if (turn[m->leg] == 0.0f) { ret = up ? (x >= 0.0f) : (x <= 0.0f); }
    else {
        /* where the current peaks if reversed now (the delay's periods on), and half a step: the peak within
         * half a step. The steps grow where the incremental inductance falls with the current (syre-thor's
         * L_q from 34 mH at zero to 2.3 mH at i_max): the last step taken on as grown by the ratio of the last
         * two (squared: their sum over the delay's periods at most), else the locked THOR's q sweep at
         * i_d = i_max/4 passed its 43 A by 5.4 A, beyond the sequence's 1.1 i_max */
        const float dx = x - m->x_prev;
        const float g = ((dx * m->dx_last) > 0.0f) ? fs_clampf(dx / m->dx_last, 1.0f, 2.0f) : 1.0f;
        const float ahead = x + ((m->cfg.delay + 0.5f) * dx * g * g);
        const float at = turn[m->leg] * m->I_amp;
        if (up ? (ahead >= at) : (ahead <= -at)) { m->leg++; }   /* the voltage turns now, the current a delay later (crossings reads on till then) */
        ret = false;
    }
    m->dx_last = x - m->x_prev;
    return ret;
}

/* +-U, and the drop the current meets fed forward (R_s x and the inverter's
 * error e_x at it): the ramps up and down then take about the same time */

static float sweep_voltage(const fs_mapid *m, float x, float e_x)
{
    return ((m->leg & 1) ? -m->U : m->U) + (m->cfg.R_s * x) + e_x;
}

static void sweep_start(fs_mapid *m, float x, float y)
{
    sums_clear(m);
    m->psi_d = 0.0f;
    m->psi_q = 0.0f;
    m->leg = 0;
    m->rleg = 0;
    m->impulse = 0.0f;
    m->x_prev = x;
    m->dx_last = 0.0f;
    m->y_prev = y;
    m->k = 0;
    m->seen = 0u;   /* the caller reads the start as the pattern's first zero */
}

/* mean of a sum at grid value t, or NAN */
static float mean_at(const float *s, const int *n, int t) { return (n[t] > 0) ? s[t] / (float)n[t] : NAN; }

/* the voltage a current I needs at standstill: R_s I and the inverter's error (4/3 u_e on an axis through a leg) */
static float drop(const fs_mapid_config *c, float I) { return (c->R_s * I) + (1.3333333f * c->u_e); }

/* The exponent by which the d sweep at amplitude I and voltage U would
 * grow a misalignment of the free rotor (fs_mapid.h): the integral over
 * the sweep of the growth rate sqrt(p K(i) / J) where the d current's
 * torque per el. rad, K = 1.5 p (psi_f i - (L_q - L_d) i^2), turns the
 * rotor away (K < 0), the pattern passing each |i| on either side four
 * times within a I and twice beyond (its legs at U / L_d). 0 where psi_f
 * or J is not known (a locked rotor). */
static float d_growth(const fs_mapid_config *c, float I, float U)
{
    float ret;
    if (!((c->psi_f > 0.0f) && (c->J > 0.0f) && (c->motion_max > 0.0f)) || !(U > 0.0f)) { ret = 0.0f; }
    else {
        const float p = (float)c->pole_pairs;
        const float dL = c->L_q - c->L_d;
        float sum = 0.0f;
        for (int n = 0; n < 16; ++n) {
            const float x = ((float)n + 0.5f) * I / 16.0f;
            const float w = (x < (TURN[0] * I)) ? 2.0f : 1.0f;   /* the inner part is passed twice as often */
            for (int side = -1; side <= 1; side += 2) {
                const float K = 1.5f * p * (((float)side * c->psi_f * x) - (dL * x * x));
                if (K < 0.0f) { sum += 2.0f * w * sqrtf(-p * K / c->J); }
            }
        }
        ret = sum * (I / 16.0f) * c->L_d / U;
    }
    return ret;
}

/* The d sweep's amplitude and voltage: I_REACH i_max (d_only: I_REACH_POL)
 * at the slope D_STEP; where that would grow a free rotor's misalignment
 * more than GROWTH-fold, the link's voltage (within D_STEP_MAX), then a smaller amplitude, down
 * to D_MIN i_max (the polarity's +-i_max/2 still read); below that none
 * (I_amp 0): the rotor must be locked for it. */
static void d_design(fs_mapid *m, float u_max)
{
    const fs_mapid_config *c = &m->cfg;
    fs_mapid_result *r = &m->res;
    float I = (c->d_only ? I_REACH_POL : I_REACH) * c->i_max;
    float U = fs_minf(D_STEP * c->i_max * c->L_d / c->Ts, fs_maxf((U_SWEEP * u_max) - drop(c, I), 0.0f));
    const float e_max = GROWTH_EXP;
    r->d_limit = FS_MAPID_LIM_DISC;
    if (d_growth(c, I, U) > e_max) {
        U = fs_maxf(U, fs_minf((U_SWEEP * u_max) - drop(c, I), D_STEP_MAX * c->i_max * c->L_d / c->Ts));
        while ((d_growth(c, I, U) > e_max) && (I > (D_MIN * c->i_max))) { I = fs_maxf(0.95f * I, D_MIN * c->i_max); }
        r->d_limit = FS_MAPID_LIM_UNSTABLE;
        if (d_growth(c, I, U) > e_max) { I = 0.0f; }
    }
    m->I_amp = I;
    r->d_amp = I;
    m->U = U;
    r->d_growth = d_growth(c, I, U);
}

/* ---- D: the d axis at i_q = 0 ---- */
static void d_finish(fs_mapid *m)
{
    fs_mapid_result *r = &m->res;
    const int n = FS_MAPID_ND / 2;
    const float z = mean_at(m->s_x, m->s_n, n);
    for (int k = 0; k < FS_MAPID_ND; ++k) {
        /* complete: the pattern reads a value 4 times within its inner turning points, twice beyond, zero 5 times */
        const bool full = (m->s_n[n] == 5) && ((k == n) || (m->s_n[k] == 2) || (m->s_n[k] == 4));
        r->n_d[k] = full ? m->s_n[k] : 0;
        r->dpsi_d[k] = full ? (mean_at(m->s_x, m->s_n, k) - z) : 0.0f;
    }
    /* the incremental L_d at +-3/4 i_max from the current's steps up and down near it, where the sweep
     * took POL_STEPS each way on both sides, else at +-i_max/2. Near zero current the magnet's own
     * saturation of the ribs sets the slope, and a rib the magnet saturates is relieved by the d current
     * that adds to the magnet: on the PM-SyRMs' maps the incremental L_d peaks at a positive d current
     * (syre-thor 16 mH at +5.5 A against 5 mH at 0; the Baldor 44 mH at +4.7 A against 26) and is still
     * higher at +i_max/2 than at -i_max/2 (thor 3.00 against 2.86 mH, the Baldor 18.3 against 17.7), so
     * the test there took the north for the south and mirrored their locked maps (39 % and 13 % of psi_f
     * off). Further out the main path's saturation, which follows the total d flux the magnet raises on
     * its north, decides as on an IPM: thor 2.52 against 2.66 mH, the Baldor 15.4 against 17.0 at 3/4. */
    int t_pol = n + 3;
    for (int side = -3; side <= 3; side += 6) {
        if ((m->c_up[n + side] < POL_STEPS) || (m->c_dn[n + side] < POL_STEPS)) { t_pol = n + 2; }
    }
    const int kp = t_pol - n;
    for (int side = -1; side <= 1; side += 2) {
        const int t = n + (kp * side);
        const float up = m->c_up[t] ? m->s_up[t] / (float)m->c_up[t] : 0.0f;
        const float dn = m->c_dn[t] ? m->s_dn[t] / (float)m->c_dn[t] : 0.0f;
        const float L = ((up - dn) > 0.0f) ? 2.0f * m->U * m->cfg.Ts / (up - dn) : 0.0f;
        if (side < 0) { r->L_neg = L; } else { r->L_pos = L; }
    }
    r->pol_level = 0.25f * (float)kp;
    if ((r->L_pos > 0.0f) && (r->L_neg > 0.0f)) { r->asym = (r->L_neg - r->L_pos) / fs_maxf(r->L_neg, r->L_pos); }
    /* the axis' offset from the q flux at +-i_max/2 (the held axis' flux is in s_y): psi_q,frame =
     * offset (psi_d(i_d) - psi_f - L_q i_d), psi_d's change read by the sweep itself (saturated) */
    if (m->s_n[n + 2] && m->s_n[n - 2]) {
        const float dq = mean_at(m->s_y, m->s_n, n + 2) - mean_at(m->s_y, m->s_n, n - 2);
        const float dd = mean_at(m->s_x, m->s_n, n + 2) - mean_at(m->s_x, m->s_n, n - 2) - (m->cfg.L_q * m->cfg.i_max);
        if (fabsf(dd) > 0.0f) { r->axis_offset = fs_clampf(dq / dd, -0.2f, 0.2f); }
    }
    /* decided on enough steps: a low-inductance machine on a high link
     * (zoo machine 39: 0.13 mH, 637 V, a leg error of 16 V the sweep's
     * voltage must clear) steps 20 % of i_max a sample, a step or two near
     * each of +-i_max/2, where the reversals' overshoot is: no polarity */
    int steps = 0x40000000;   /* 2^30 */
    for (int side = -kp; side <= kp; side += 2 * kp) {
        steps = (m->c_up[n + side] < steps) ? m->c_up[n + side] : steps;
        steps = (m->c_dn[n + side] < steps) ? m->c_dn[n + side] : steps;
    }
    r->decided = (fabsf(r->asym) >= POL_MIN) && (steps >= POL_STEPS);
    if (r->decided && (r->asym < 0.0f) && !m->cfg.pol_known) {   /* the frame's d axis is the magnet's south: turn it by pi */
        r->flipped = 1;
        r->asym = -r->asym;
        m->torque_imp = -m->torque_imp;   /* the q axis turned too */
        const float Lp = r->L_pos;
        r->L_pos = r->L_neg;
        r->L_neg = Lp;
        for (int k = 0; k < n; ++k) {
            const float a = r->dpsi_d[k];
            const float b = r->dpsi_d[FS_MAPID_ND - 1 - k];
            const int na = r->n_d[k];
            const int nb = r->n_d[FS_MAPID_ND - 1 - k];
            r->dpsi_d[k] = -b;
            r->dpsi_d[FS_MAPID_ND - 1 - k] = -a;
            r->n_d[k] = nb;
            r->n_d[FS_MAPID_ND - 1 - k] = na;
        }
    }
}

/* The level's d current would grow a misalignment of the free rotor more
 * than GROWTH-fold over its time (fs_mapid.h); never where psi_f or J is
 * not known (a locked rotor). */
static bool unstable(const fs_mapid *m, int n_settle)
{
    bool ret;
    const fs_mapid_config *c = &m->cfg;
    if (!((c->psi_f > 0.0f) && (c->J > 0.0f) && (c->motion_max > 0.0f)) || (m->I_d == 0.0f)) { ret = false; }
    else {
        const float p = (float)c->pole_pairs;
        const float I = m->I_d;
        const float K = 1.5f * p * ((c->psi_f * I) - (c->L_q - c->L_d) * I * I);   /* N m per el. rad of misalignment, restoring when > 0 */
        if (K >= 0.0f) { ret = false; }
        else {
            const float rate = sqrtf(-p * K / c->J);
            const int n_L = (2 * n_settle) + (7 * m->n_rise);
            const float t_L = (float)n_L * c->Ts;   /* in, the pattern's 6.5 rises and the trim, out */
            ret = coshf(rate * t_L) > GROWTH;
        }
    }
    return ret;
}

/* ---- Q(k): the sweep's amplitude and voltage at d level I_d ---- */
static void q_design(fs_mapid *m, int kk, float u_max)
{
    const fs_mapid_config *c = &m->cfg;
    fs_mapid_result *r = &m->res;
    const float I_d = m->I_d;
    float I = sqrtf(fs_maxf((I_REACH_Q * I_REACH_Q * c->i_max * c->i_max) - (I_d * I_d), 0.0f));
    /* the ramp's voltage: what the link leaves after the held axis' drop and this one's (fed forward) */
    const float U_lim = fs_maxf((U_SWEEP * u_max) - drop(c, fabsf(I_d)) - drop(c, I), 0.0f);
    int lim = FS_MAPID_LIM_DISC;
    /* the angular acceleration per A of q current at the rotor's rest (el. rad/s^2) */
    const float p = (float)c->pole_pairs;
    const float k_a = ((c->psi_f > 0.0f) && (c->J > 0.0f) && (c->motion_max > 0.0f))
                          ? (p * p * 1.5f * (c->psi_f + fabsf(c->L_q - c->L_d) * fabsf(I_d)) / c->J) : 0.0f;
    const float t_min = (float)N_Q_MIN * c->Ts;
    if (k_a > 0.0f) {
        /* SWING a t^2 <= motion_max at the sampling's shortest rise, and at
         * the voltage's (t = L_q I / U_lim: I^3 <= motion U_lim^2 / (SWING k_a L_q^2)) */
        const float I_s = c->motion_max / (SWING * k_a * t_min * t_min);
        if (I_s < I) {
            I = I_s;
            lim = FS_MAPID_LIM_MOTION;
        }
        const float I_v = cbrtf(c->motion_max * U_lim * U_lim / (SWING * k_a * c->L_q * c->L_q));
        if (I_v < I) {
            I = I_v;
            lim = FS_MAPID_LIM_VOLTAGE;
        }
    } else if (c->L_q * I / ((float)N_Q_MAX_LOCKED * c->Ts) > U_lim) {   /* the voltage alone bounds it, at the longest rise */
        I = U_lim * (float)N_Q_MAX_LOCKED * c->Ts / c->L_q;
        lim = FS_MAPID_LIM_VOLTAGE;
    } else {
        /* locked, within the voltage: the current stays */
    }
    /* the rise: as long as the motion allows, within N_Q_MIN..N_Q_MAX samples (a locked rotor:
     * N_Q_MAX_LOCKED) and the voltage */
    float t_q = (float)((k_a > 0.0f) ? N_Q_MAX : N_Q_MAX_LOCKED) * c->Ts;
    if ((k_a > 0.0f) && (I > 0.0f)) { t_q = fs_minf(t_q, sqrtf(c->motion_max / (SWING * k_a * I))); }
    t_q = fs_maxf(t_q, fs_maxf(t_min, (U_lim > 0.0f) ? (c->L_q * I / U_lim) : t_min));
    const float n_rise_f = (t_q / c->Ts) + 0.5f;
    m->n_rise = (int)n_rise_f;
    m->U = (I > 0.0f) ? fs_minf(c->L_q * I / t_q, U_lim) : 0.0f;
    m->I_amp = I;
    r->i_q_amp[kk] = I;
    r->limit[kk] = lim;
    r->motion[kk] = SWING * k_a * I * t_q * t_q;
}

static void q_finish(fs_mapid *m, int kk)
{
    fs_mapid_result *r = &m->res;
    const int n = FS_MAPID_NQ;
    const float z = mean_at(m->s_y, m->s_n, n);
    const bool z_full = m->s_n[n] == 5;   /* the start, three crossings, the end */
    for (int j = 1; j <= FS_MAPID_NQ; ++j) {
        const int tp = n + j;
        const int tm = n - j;
        /* read on both sides alike: 4 times inside the inner turning points, twice beyond */
        const bool full = z_full && (m->s_n[tp] == m->s_n[tm]) && ((m->s_n[tp] == 2) || (m->s_n[tp] == 4));
        r->n_q[kk][j - 1] = full ? (m->s_n[tp] + m->s_n[tm]) : 0;
        if (!full) { continue; }
        r->psi_q[kk][j - 1] = 0.5f * (mean_at(m->s_x, m->s_n, tp) - mean_at(m->s_x, m->s_n, tm));
        r->dpsi_dq[kk][j - 1] = 0.5f * (mean_at(m->s_y, m->s_n, tp) + mean_at(m->s_y, m->s_n, tm)) - z;
        r->i_d_at[kk][j - 1] = 0.5f * (mean_at(m->s_i, m->s_n, tp) + mean_at(m->s_i, m->s_n, tm));
    }
    r->psi_q_end[kk] = m->psi_q;
}

/* The d flux at this level's d current and no q current: psi_f and the d
 * sweep's reading there (where it read the level; else L_d I_d). */
static float level_psi_d(const fs_mapid *m)
{
    const int kk = Q_ORDER[m->level] + (FS_MAPID_ND / 2);
    return m->cfg.psi_f + ((m->res.n_d[kk] > 0) ? m->res.dpsi_d[kk] : (m->cfg.L_d * m->I_d));
}

fs_dq fs_mapid_step(fs_mapid *m, fs_dq i_in, fs_dq e_in, float u_max)
{
    const fs_mapid_config *c = &m->cfg;
    const float sgn = m->res.flipped ? -1.0f : 1.0f;   /* a frame on the south pole, turned by pi */
    const fs_dq i = {sgn * i_in.d, sgn * i_in.q};
    const fs_dq e = {sgn * e_in.d, sgn * e_in.q};
    const fs_dq i_prev = (m->stage == (int)FS_MAPID_QSWEEP) ? (fs_dq){m->y_prev, m->x_prev} : (fs_dq){m->x_prev, m->y_prev};
    const float lim = 0.9f * u_max;
    fs_dq u = {0.0f, 0.0f};
    const float n_settle_f = N_SETTLE / (c->w_c * c->Ts);
    const int n_settle = (int)n_settle_f + 1;
    m->torque_imp += c->Ts * torque_weight(c, i.d) * i.q;
    switch (m->stage) {
    case FS_MAPID_DSWEEP: {
        const bool away = (m->k == 0) && ((fabsf(i.d) > (0.02f * c->i_max)) || fabsf(i.q) > (0.02f * c->i_max));
        if ((m->n_trim > 0) || away) {   /* the sweep starts from zero current (a restart, or the caller's last bias) */
            u.d = hold(&m->pi_d, 0.0f, i.d, lim);
            u.q = hold(&m->pi_q, 0.0f, i.q, fs_maxf(lim - fabsf(u.d), 0.0f));
            if (m->n_trim > 0) {
                --m->n_trim;
                if (m->n_trim == 0) { m->k = 0; }
            }
            break;
        }
        if (m->k == 0) {
            sweep_start(m, i.d, i.q);
            if (m->n_rise == 0) { d_design(m, u_max); }   /* the first start; a restart keeps the U it raised */
            m->n_rise = 1;
            if (!(m->I_amp > 0.0f)) {   /* no sweep the free rotor would stand: nothing read */
                d_finish(m);
                m->stage = c->d_only ? FS_MAPID_DONE : FS_MAPID_IN;
                m->level = 0;
                m->k = 0;
                m->n_rise = 0;
                break;
            }
            m->s_n[FS_MAPID_ND / 2] = 1;   /* the start reads 0 (its flux is the origin) */
            m->seen = 1u << ((unsigned)FS_MAPID_ND / 2u);
        } else {
            const float pd0 = m->psi_d;
            const float pq0 = m->psi_q;
            integrate(m, i, e, i_prev, c->psi_f);
            crossings(m, i.d, i.q, m->psi_d, m->psi_q, pd0, pq0, FS_MAPID_ND / 2, 0.25f * c->i_max);
        }
        m->k++;
        const int leg = m->leg;
        if ((leg == 0) && (m->k > 1)) { m->impulse += i.d - m->x_prev; }   /* the first leg's steps */
        const bool over = leg_next(m, i.d, TURN);
        const float step0 = m->U * c->Ts / c->L_d;   /* a sample's step at U alone */
        const bool stalled = (leg == 0) && (float)m->k > ((3.0f * TURN[0] * m->I_amp / step0) + c->delay + 2.0f);
        if (((leg == 0) && (m->leg == 1)) || stalled) {
            /* the first leg's steps against what U alone would make give the drop the feedforward
             * leaves (R_s and the inverter's error, before they are known; about half its value at the
             * sweep's ends, in the leg's mean); above a quarter of U the legs' slopes are too far apart
             * (a low link's R_s i, a high link's dead time, stall the rise): U raised to four times it
             * (twice where the rise stalled), and the sweep starts again from zero current */
            const int k_prev = m->k - 1;
            const float drop_v = stalled ? (0.5f * m->U) : fs_minf(1.0f - m->impulse / (float)k_prev / step0, 1.0f) * m->U;
            const float U_max = U_SWEEP * u_max;
            if ((drop_v > (0.25f * m->U)) && (m->U < U_max) && (m->restarts < 3)) {
                m->U = fs_minf(4.0f * drop_v, U_max);
                m->restarts++;
                m->n_trim = n_settle;
                m->impulse = 0.0f;
                fs_pi_reset(&m->pi_d);
                u = (fs_dq){0.0f, 0.0f};
                break;
            }
        }
        m->x_prev = i.d;
        m->y_prev = i.q;
        u.d = sweep_voltage(m, i.d, e.d);
        u.q = hold(&m->pi_q, 0.0f, i.q, fs_maxf(lim - m->U, 0.0f));
        const float n_step_f = 1.0f / D_STEP;
        if (over || (m->k > (40 * (int)n_step_f))) {   /* over, or stuck (a current that does not follow) */
            d_finish(m);
            fs_pi_reset(&m->pi_d);
            fs_pi_reset(&m->pi_q);
            m->stage = c->d_only ? FS_MAPID_DONE : FS_MAPID_IN;
            m->level = 0;
            m->k = 0;
            m->n_rise = 0;
            m->impulse = 0.0f;
            u = (fs_dq){0.0f, 0.0f};
        }
        break;
    }
    case FS_MAPID_IN:   /* the level's d current, q at zero */
        m->I_d = 0.25f * (float)Q_ORDER[m->level] * c->i_max;
        if (m->k == 0) {
            const int kk = Q_ORDER[m->level] + (FS_MAPID_ND / 2);
            q_design(m, kk, u_max);
            if (unstable(m, n_settle)) {   /* the level would turn the rotor: not swept */
                m->res.limit[kk] = FS_MAPID_LIM_UNSTABLE;
                m->res.i_q_amp[kk] = 0.0f;
                ++m->level;
                m->stage = (m->level < N_LEVELS) ? (int)FS_MAPID_IN : (int)FS_MAPID_DONE;
                break;
            }
        }
        u.d = hold(&m->pi_d, m->I_d, i.d, lim);
        u.q = hold(&m->pi_q, 0.0f, i.q, fs_maxf(lim - fabsf(u.d), 0.0f));
        if (++m->k >= n_settle) {
            sweep_start(m, i.q, i.d);
            m->s_n[FS_MAPID_NQ] = 1;
            m->seen = (uint32_t)1u << (unsigned)FS_MAPID_NQ;
            m->stage = ((m->I_amp > 0.0f) && (m->U > 0.0f)) ? FS_MAPID_QSWEEP : FS_MAPID_OUT;
            fs_pi_reset(&m->pi_q);
        }
        m->x_prev = i.q;
        m->y_prev = i.d;
        break;
    case FS_MAPID_QSWEEP: {
        const float pd0 = m->psi_d;
        const float pq0 = m->psi_q;
        integrate(m, i, e, i_prev, level_psi_d(m));
        crossings(m, i.q, i.d, m->psi_q, m->psi_d, pq0, pd0, FS_MAPID_NQ, 0.125f * c->i_max);
        m->k++;
        const bool over = leg_next(m, i.q, TURN) || (fabsf(i.q) > (I_ABORT * c->i_max));
        m->x_prev = i.q;
        m->y_prev = i.d;
        u.q = sweep_voltage(m, i.q, e.q);
        u.d = hold(&m->pi_d, m->I_d, i.d, fs_maxf(lim - m->U, 0.0f));
        if (over) {
            q_finish(m, Q_ORDER[m->level] + (FS_MAPID_ND / 2));
            fs_pi_reset(&m->pi_q);
            m->stage = FS_MAPID_TRIM;
            m->k = 0;
            m->n_trim = -1;   /* the current to zero first */
        }
        break;
    }
    case FS_MAPID_TRIM:
        /* the q current to zero, then n_trim samples at -U against the
         * torque's impulse since the last trim (the d sweep's and the
         * levels' q current too: torque_imp) and n_trim back: a triangle
         * whose impulse dI n^2 Ts cancels it (dI = U Ts / L_q a sample, at
         * this level's torque per A) */
        u.d = hold(&m->pi_d, m->I_d, i.d, fs_maxf(lim - m->U, 0.0f));
        if (m->n_trim < 0) {
            u.q = hold(&m->pi_q, 0.0f, i.q, fs_maxf(lim - fabsf(u.d), 0.0f));
            bool settled = fabsf(i.q) < (0.02f * c->i_max);
            if (!settled) {
                ++m->k;
                settled = m->k > n_settle;
            }
            if (settled) {
                const float dI = m->U * c->Ts / c->L_q;
                const float imp = m->torque_imp / torque_weight(c, m->I_d);
                const float n_trim_f = sqrtf(fabsf(imp) / (dI * c->Ts)) + 0.5f;
                m->n_trim = (int)n_trim_f;
                m->leg = (imp > 0.0f) ? (int)1 : (int)0;   /* the first half against the impulse */
                m->k = 0;
            }
        } else {
            if (m->k == m->n_trim) { m->leg ^= 1; }
            u.q = sweep_voltage(m, i.q, e.q);
            if (++m->k > (2 * m->n_trim)) {   /* the loop takes what is left to zero */
                m->res.impulse_left[Q_ORDER[m->level] + (FS_MAPID_ND / 2)] = m->torque_imp;
                m->torque_imp = 0.0f;
                fs_pi_reset(&m->pi_q);
                m->stage = FS_MAPID_OUT;
                m->k = 0;
                m->impulse = 0.0f;   /* OUT sums the back-EMF in it */
            }
        }
        m->x_prev = i.q;
        m->y_prev = i.d;
        break;
    case FS_MAPID_OUT:   /* back to zero current; a q voltage there beyond the inverter's error: the rotor turning */
        u.d = hold(&m->pi_d, 0.0f, i.d, lim);
        u.q = hold(&m->pi_q, 0.0f, i.q, fs_maxf(lim - fabsf(u.d), 0.0f));
        if (m->k >= (n_settle / 2)) { m->impulse += u.q - e.q; }   /* the second half: the current back at zero */
        if (++m->k >= n_settle) {
            const int kk = Q_ORDER[m->level] + (FS_MAPID_ND / 2);
            const int n_read = n_settle - (n_settle / 2);
            const float e_q = m->impulse / (float)n_read;   /* V: the mean back-EMF */
            const int n_L = (2 * n_settle) + (7 * m->n_rise);
            const float t_L = (float)n_L * c->Ts;
            m->k = 0;
            ++m->level;
            m->stage = (m->level < N_LEVELS) ? (int)FS_MAPID_IN : (int)FS_MAPID_DONE;
            if ((c->psi_f > 0.0f) && fabsf(e_q) > ((c->psi_f * EMF_TURN / t_L) + (1.3333333f * c->u_e))) {
                m->res.limit[kk] = FS_MAPID_LIM_MOVING;
                m->stage = FS_MAPID_DONE;
            }
            m->impulse = 0.0f;
        }
        m->x_prev = i.q;
        m->y_prev = i.d;
        break;
    default:
        break;
    }
    const float turn = (m->res.flipped ? -1.0f : 1.0f) * sgn;   /* -1 where the frame was turned just now */
    m->e_prev_d = turn * e.d;
    m->e_prev_q = turn * e.q;
    m->u_out[1] = m->u_out[0];
    m->u_out[0] = u;
    return (fs_dq){sgn * u.d, sgn * u.q};
}
