#include "fs_ident.h"
#include "fs_math.h"

#include <stddef.h>

/* Design values, each with its reason (fs_ident.h has the sequence). */
static const float LEV_FRAC[FS_IDENT_NLEV] = {1.0f, 0.75f, 0.5f, 0.25f, 0.125f, 0.0625f, 0.03125f};
/* levels of i_test: the top three well above the knee of the dead-time
 * error (the ripple's half amplitude) for R_s; the rest halving, to see the knee */
#define I_TEST 0.6f       /* of i_max: the levels' top current unless given (the old top level) */
#define T_LEVEL 0.1f      /* s: the top three levels' window per sign unless given (0.2 s a level before the alternation; the rest half) */
#define I_PROBE 0.25f     /* of i_max: the probe pulse's target peak, far below any trip */
#define W_C_TS 0.1f       /* current loop bandwidth x Ts: a tenth of the sampling rate in rad/s, robust to the probe's factor-two error in L and to a period of delay */
#define N_HF 10           /* samples per HF period: w_h Ts = 2 pi / 10, slow enough for the sampled model, fast against L/R */
#define HF_SKIP 20        /* periods before the HF phasors are summed: the R-L transient */
#define HF_MEAS 100       /* periods summed: the noise on the phasor falls as 1/sqrt(N) */
#define N_NOISE 32        /* START: periods at zero voltage for the sensors' noise (its rms within 15 %) */
#define AX_CHUNK 10       /* AXIS: periods on one axis before it turns to the other (its carrier's mean torque alternating) */
#define AX_SKIP 2         /* periods after a turn before the sums: the carrier starts and ends at zero current, R and the delay
                             leave a transient of a period or two */
#define AX_TURNS (HF_MEAS / AX_CHUNK)   /* turns per axis: HF_MEAS periods summed on each (even: whole Walsh blocks A B B A) */
#define AX_PRE ((int)HF_SKIP / 2)  /* AXIS's prelude A B B A of AX_PRE periods each: HF_SKIP on each axis, not summed (the loops' start) */
#define I_HF 0.1f         /* of i_max: the q carrier's amplitude, small against saturation, large against noise */
#define H2_MAX 0.05f      /* LDQ's d carrier: its current's second harmonic over the fundamental above which the axis is lopsided over
                             the swing and the carrier is halved (5 %: L_d's goal; fs_ident.c step_ldq) */
#define L_CONV 0.01f      /* LDQ's d carrier: a pass that moved L_d by less than this (a fifth of its goal) ends the halvings */
#define LD_S_MIN 0.0625f  /* the d carrier's least scale, 1 / 2^4: four halvings at most (the SNR check in step_ldq bounds it first where the noise is higher): the carrier is sized from the probe's L, which on a salient rotor is not the d axis': the THOR's first was 15 A, not 0.15 i_max = 6.6 A */
#define I_HF_D 0.15f      /* of i_max: the d carrier's, at zero current: larger, against the dead time's error (60 % larger: L_d +20 % on zoo machine 60 at 0.1) */
#define SAL_MIN 0.03f     /* AXIS: the saliency (L_q - L_d)/(L_q + L_d) below which the axis is not trusted (its noise: 120 periods' phasors within 0.5 %) */
#define I_ALIGN 0.3f      /* of i_max: ALIGN's current (the levels' former top, halved) */
#define I_IF 0.5f         /* of i_max: the I/f current, half the torque at a 90 deg load angle to spare */
#define I_ACC 0.3f        /* of i_max: the first try of the acceleration current */
#define I_SHORT 0.3f      /* of i_max: the shorted q axis's current limit, with the top level still within i_max */
#define U_SPIN 0.5f       /* of the linear limit: the EMF the spin may reach, leaving room for R i and L di/dt */
#define U_ACC 0.85f       /* of the linear limit: the acceleration stops there */
#define U_DCURVE 0.8f     /* of the linear limit: DCURVE's levels whose voltage w (psi_f + L_d i_d) stays below */
#define DCURVE_LEVELS 2   /* DCURVE's levels to +-2 i_max / 4: beyond, the frame's small lock error makes torque enough to lose it */
#define DCURVE_LOCK 0.02f /* rad: the PLL's mean phase error a DCURVE level is read within (1 el.deg: psi_d to 2e-4) */
#define MOTION_MAX 0.017453292f   /* el. rad (1 el.deg): the map's q sweeps' motion bound unless given */

const char *fs_ident_reason_str(int reason)
{
    static const char *const s[FS_IDR__COUNT] = {
        "", "the current did not answer the largest voltage pulse", "current beyond i_max",
        "signal not above its noise", "fit residual too large", "the rotor moved at standstill",
        "no back-EMF: the rotor did not turn", "the rotor did not follow the I/f frame",
        "voltage beyond the linear range", "an earlier quantity failed",
        "magnet axis off the alignment", "the speed changed too fast to fit",
        "friction above the test torque", "skipped: the rotor may not turn", "skipped: the rotor is locked",
        "skipped: not asked for", "the sweeps did not read the grid",
        "the d sweep to the current limit would turn the free rotor away: lock it",
        "no polarity seen standing (no saturation asymmetry) and the rotor may not turn: lock it",
        "no saliency: the d axis is not seen standing, and the rotor may not be turned to it"};
    return ((reason >= 0) && (reason < (int)FS_IDR__COUNT)) ? s[reason] : "?";
}

const char *fs_ident_step_str(int step)
{
    static const char *const s[FS_IDENT_NSTEPS] = {"start", "probe", "axis", "align", "polarity", "levels", "ldq", "map",
                                                   "check", "spin", "flux", "dcurve", "accel", "coast", "done", "failed"};
    return ((step >= 0) && (step < (int)FS_IDENT_NSTEPS)) ? s[step] : "?";
}

FS_COLD fs_status fs_ident_init(fs_ident *id, const fs_ident_config *cfg)
{
    fs_status ret;
    if (!id || !cfg) { ret = FS_ERR_NULL; }
    else if (!fs_pos(cfg->Ts)) { ret = FS_ERR_TS; }
    else if ((cfg->delay != 0.0f) && (cfg->delay != 1.0f)) { ret = FS_ERR_PARAM; }
    else if (cfg->pole_pairs < 1) { ret = FS_ERR_POLE_PAIRS; }
    else if (!fs_pos(cfg->i_max)) { ret = FS_ERR_I_MAX; }
    else if (!fs_pos(cfg->w_spin) || !fs_pos(cfg->t_ramp) || !fs_nonneg(cfg->u_dc_min)) { ret = FS_ERR_PARAM; }
    else if (cfg->t_ramp < (100.0f * cfg->Ts)) { ret = FS_ERR_PARAM; }   /* a ramp of fewer samples is a step */
    else if (((cfg->standstill_only | cfg->locked | cfg->skip_map) & ~1) != 0) { ret = FS_ERR_PARAM; }   /* flags: 0 or 1 */
    else if (!fs_nonneg(cfg->i_test) || (cfg->i_test > cfg->i_max) || !fs_nonneg(cfg->t_level) || !fs_nonneg(cfg->psi_f_hint)
        || !fs_nonneg(cfg->J_hint) || !fs_nonneg(cfg->motion_max)) {
        ret = FS_ERR_PARAM;
    }
    else if ((cfg->t_level > 0.0f) && (cfg->t_level < (100.0f * cfg->Ts))) { ret = FS_ERR_PARAM; }   /* fewer samples than batches can hold */
    else {
        id->cfg = *cfg;
        fs_ident_reset(id);
        ret = FS_OK;
    }
    return ret;
}

/* the HF phasors' sums cleared */
static void hf_clear(fs_ident *id)
{
    id->hf_u[0] = 0.0f;
    id->hf_u[1] = 0.0f;
    id->hf_i[0][0] = 0.0f;
    id->hf_i[0][1] = 0.0f;
    id->hf_i[1][0] = 0.0f;
    id->hf_i[1][1] = 0.0f;
    id->hf_i2[0] = 0.0f;
    id->hf_i2[1] = 0.0f;
}

static void acc_clear(fs_ident *id)
{
    id->s_u = 0.0f;
    id->s_i = 0.0f;
    id->s_uu = 0.0f;
    id->s_ib2 = 0.0f;
    id->s_ii = 0.0f;
    id->s_ia = 0.0f;
    id->e_abs = 0.0f;
    id->w_abs = 0.0f;
    id->n_acc = 0;
}

void fs_ident_reset(fs_ident *id)
{
    static const fs_ident_result none = { 0 };   /* all zero: every quantity pending */
    const fs_ident_config *c = &id->cfg;
    id->res = none;
    /* what the configuration leaves out is skipped, with its reason */
    const int run_reason = c->locked ? (int)FS_IDR_LOCKED : c->standstill_only ? (int)FS_IDR_STANDSTILL : (int)FS_IDR_NONE;
    if (run_reason != (int)FS_IDR_NONE) {
        for (int q = FS_IDQ_PSI_F; q <= (int)FS_IDQ_FRICTION; ++q) {
            id->res.status[q] = FS_IDS_SKIPPED;
            id->res.reason[q] = run_reason;
        }
    }
    if (c->skip_map != 0) {
        id->res.status[FS_IDQ_MAP] = FS_IDS_SKIPPED;
        id->res.reason[FS_IDQ_MAP] = FS_IDR_NOT_ASKED;
    }
    id->step = FS_IDENT_START;
    id->k = 0;
    id->sub = 0;
    id->L0 = 0.0f;
    id->u_p = 0.0f;
    id->n_p = 2;
    id->i_peak = 0.0f;
    id->i_peak_b = 0.0f;
    id->L0_min = 0.0f;
    id->sigma_i = 0.0f;
    id->w_c = W_C_TS / c->Ts;
    fs_pi_reset(&id->pi_d);
    fs_pi_reset(&id->pi_q);
    id->u_max = 0.0f;
    id->theta_s = 0.0f;
    id->aligned = 0;
    id->pol_known = 0;
    id->i_ref0 = 0.0f;
    id->hf_scale = 0.0f;
    id->ld_L_prev = 0.0f;
    acc_clear(id);
    id->u0 = 0.0f;
    id->i0 = 0.0f;
    for (int b = 0; b < FS_IDENT_NBATCH; ++b) { id->batch[b] = 0.0f; }
    hf_clear(id);
    for (int a = 0; a < 8; ++a) {
        (&id->ax_i[0][0][0])[a] = 0.0f;
        (&id->ax_u[0][0][0])[a] = 0.0f;
    }
    id->U_h = 0.0f;
    id->w_h = 0.0f;
    id->theta = 0.0f;
    id->w = 0.0f;
    id->w_target = 0.0f;
    id->bw_pll = 0.0f;
    id->i_if = 0.0f;
    id->i_acc = 0.0f;
    id->w0 = 0.0f;
    id->u_prev[0].alpha = 0.0f;
    id->u_prev[0].beta = 0.0f;
    id->u_prev[1] = id->u_prev[0];
    id->u_dq.d = 0.0f;
    id->u_dq.q = 0.0f;
    id->e_abs = 0.0f;
    id->w_abs = 0.0f;
    id->tries = 0;
    id->rec_n = 0;
    id->rec_k = 0;
    id->rec_dec = 1;
    id->g_acc = 0.0f;
    id->T_acc = 0.0f;
    id->t_acc = 0.0f;
    id->w_acc = 0.0f;
    id->w_level = 0.0f;
}

float fs_ident_leg_error(const fs_ident *id, float i)
{
    float ret;
    const float ue = id->res.u_e;
    const float ie = id->res.i_e;
    if (id->res.status[FS_IDQ_VERR] != (int)FS_IDS_OK) { ret = 0.0f; }
    else {
        ret = ue * i / sqrtf((i * i) + (ie * ie) + 1e-30f);
    }
    return ret;
}

/* The quantity q failed for a reason; the ones not measured yet fail as
 * needing it, and the sequence ends. */
static void ident_fail(fs_ident *id, int q, int reason)
{
    for (int k = 0; k < (int)FS_IDQ_N; ++k) {
        if (id->res.status[k] == (int)FS_IDS_PENDING) {
            id->res.status[k] = FS_IDS_FAILED;
            id->res.reason[k] = (k == q) ? reason : (int)FS_IDR_PREREQ;
        }
    }
    if (id->res.status[q] != (int)FS_IDS_FAILED) {   /* a quantity already given is withdrawn */
        id->res.status[q] = FS_IDS_FAILED;
        id->res.reason[q] = reason;
    }
    id->step = FS_IDENT_FAILED;
}

static void ident_ok(fs_ident *id, int q)
{
    id->res.status[q] = FS_IDS_OK;
    id->res.reason[q] = FS_IDR_NONE;
}

static void ident_goto(fs_ident *id, int step)
{
    fs_ident_result *r = &id->res;
    if ((step != id->step) && (r->n_visit < FS_IDENT_NVISIT)) {
        r->visit_step[r->n_visit] = step;
        r->visit_at[r->n_visit++] = r->n_total;
    }
    id->step = step;
    id->k = 0;
    id->sub = 0;
    acc_clear(id);
}

/* The current loops' PIs for inductances L_d, L_q and resistance R. */
static void ident_design_pi(fs_ident *id, float L_d, float L_q, float R)
{
    const float u_lim = (id->u_max > 0.0f) ? id->u_max : 1.0f;
    (void)fs_pi_design_init(&id->pi_d, id->cfg.Ts, L_d, R, id->w_c, u_lim);   /* a failed design leaves the PI as it was */
    (void)fs_pi_design_init(&id->pi_q, id->cfg.Ts, L_q, R, id->w_c, u_lim);
}

/* The inverter's error at the sampled currents i_ab while the voltage u_ab
 * (the reference applied over the sampled period) is on the winding. A
 * centre-aligned carrier samples in a zero vector, where the winding of phase
 * x sees -u_x (its mean voltage); its leg's two edges sit (1 - d_x) T_pwm / 2
 * either side of the sample, d_x = 1/2 + u_x / u_dc, so the ripple has moved
 * the current there by about +-|u_x| (1 - 2 |u_x| / u_dc) T_pwm / (4 L), in
 * opposite directions (exact for the leg that switches first; L = (L_d +
 * L_q) / 2): below that displacement the two edges' errors cancel, so it is
 * the leg's knee beside LEVELS' i_e. LEVELS fitted i_e at dc, where
 * u = R i keeps the ripple small; at speed (the EMF) and in MAP's sweeps the
 * ripple is amperes: with LEVELS' knee alone, the siemens-1ft6084 bench
 * (2.5 us dead time at 5 kHz, 7 V a leg) read psi_f 3.9 % low at zero current
 * (the loop's 25 mA lag under the coast's falling EMF took u_e for its sign)
 * and its d sweeps a 20 % asymmetry on a linear machine. */
static fs_ab ident_inv_error(const fs_ident *id, fs_ab i_ab, fs_ab u_ab)
{
    float i_abc[3];
    float u_abc[3];
    float e_abc[3];
    const fs_ident_result *r = &id->res;
    const float T = (id->cfg.T_pwm > 0.0f) ? id->cfg.T_pwm : id->cfg.Ts;
    const float L = 0.5f * (r->L_d + r->L_q);
    const float k_r = (L > 0.0f) ? ((0.25f * T) / L) : 0.0f;   /* A per V: the ripple's displacement at a leg's edges */
    fs_inv_clarke(i_ab, i_abc);
    fs_inv_clarke(u_ab, u_abc);
    const float u_dc = FS_SQRT3 * id->u_max;
    for (int x = 0; x < 3; ++x) {
        const float d = k_r * u_abc[x] * ((u_dc > 0.0f) ? fs_maxf(1.0f - (2.0f * fabsf(u_abc[x]) / u_dc), 0.0f) : 0.0f);
        const float ie = r->i_e;
        e_abc[x] = (r->status[FS_IDQ_VERR] != (int)FS_IDS_OK) ? 0.0f
                 : (r->u_e * i_abc[x] / sqrtf((i_abc[x] * i_abc[x]) + (ie * ie) + (d * d) + 1e-30f));
    }
    return fs_clarke(e_abc[0], e_abc[1], e_abc[2]);
}

/* PI output with anti-windup against a realised value set by the caller. */
static float pi_out(const fs_pi *pi, float ref, float meas) { return fs_pi_output(pi, ref, meas); }

/* Least-squares slope of the record between samples [a, b): its slope (w per
 * s) and the means of t and w. Returns false with fewer than 3 points. */
static bool rec_fit(const fs_ident *id, const float *y, int a, int b, float *slope, float *t_m, float *y_m)
{
    bool ret;
    const int n = b - a;
    if (n < 3) { ret = false; }
    else {
        float st = 0.0f;
        float sy = 0.0f;
        for (int k = a; k < b; ++k) {
            st += id->rec_t[k];
            sy += y[k];
        }
        st /= (float)n;
        sy /= (float)n;
        float stt = 0.0f;
        float sty = 0.0f;
        for (int k = a; k < b; ++k) {
            const float dt = id->rec_t[k] - st;
            stt += dt * dt;
            sty += dt * (y[k] - sy);
        }
        if (!(stt > 0.0f)) { ret = false; }
        else {
            *slope = sty / stt;
            *t_m = st;
            *y_m = sy;
            ret = true;
        }
    }
    return ret;
}

/* Records (t, w, g) every rec_dec-th call; when full, pairs are averaged and the
 * decimation doubles, so any duration fits in FS_IDENT_NREC points. */
static void rec_push(fs_ident *id, float t, float w, float g)
{
    if (++id->rec_k < id->rec_dec) { /* nothing more to do */ }
    else {
        id->rec_k = 0;
        if (id->rec_n == FS_IDENT_NREC) {
            for (int k = 0; k < (FS_IDENT_NREC / 2); ++k) {
                id->rec_t[k] = 0.5f * (id->rec_t[2 * k] + id->rec_t[(2 * k) + 1]);
                id->rec_w[k] = 0.5f * (id->rec_w[2 * k] + id->rec_w[(2 * k) + 1]);
                id->rec_g[k] = 0.5f * (id->rec_g[2 * k] + id->rec_g[(2 * k) + 1]);
            }
            id->rec_n = FS_IDENT_NREC / 2;
            id->rec_dec *= 2;
        }
        id->rec_t[id->rec_n] = t;
        id->rec_w[id->rec_n] = w;
        id->rec_g[id->rec_n] = g;
        id->rec_n++;
    }
}

static void rec_clear(fs_ident *id)
{
    id->rec_n = 0;
    id->rec_k = 0;
    id->rec_dec = 1;
    id->g_acc = 0.0f;
}

/* ---- PROBE: on alpha +u_p for n_p samples, -u_p for 2 n_p, +u_p for n_p; the same on beta; rest 2 n_p + 4 ----
 * The current on each axis a triangle to +i_peak, through zero to -i_peak
 * and back: the magnet's torque, odd in the current (1.5 p psi_f i_q), has
 * no impulse. The reluctance torque, even in it (1.5 p (L_d - L_q) i_d
 * i_q), is not cancelled by the sign. The same voltage on beta, 90
 * el.deg on, cancels it at any angle: a voltage pulse at psi from d drives
 * (i_d, i_q) = f(t) (cos psi / L_d, sin psi / L_q), i_d i_q = f^2 sin(2 psi)
 * / (2 L_d L_q), and psi + 90 deg flips sin(2 psi) whatever L_d and L_q
 * (the same current on both would not). A pulse +u_p, -u_p on alpha alone
 * (one sign of current) kicked the free, frictionless Prius MG2 at 137 el.deg
 * (50 A for 1.6 ms: 0.74 rad/s, both parts the same sign there), which kept
 * it through AXIS: 25 el.deg, its axis read while it turned. */
static fs_ab step_probe(fs_ident *id, fs_ab i)
{
    fs_ab ret;
    const fs_ident_config *c = &id->cfg;
    const int n_cycle = (10 * id->n_p) + 4;
    if ((id->k == 0) && (id->sub == 0)) {
        id->u_p = 0.01f * id->u_max;   /* the smallest pulse: 1 % of the link */
        id->u_pb = id->u_p;
        id->i_peak_b = 0.0f;
    }
    const int kk = (id->k < (4 * id->n_p)) ? id->k : (id->k - (4 * id->n_p));   /* the position in alpha's, then beta's, pulses */
    const float up = (id->k < (4 * id->n_p)) ? id->u_p : id->u_pb;
    float v = 0.0f;
    if (kk < id->n_p) { v = up; }
    else if (kk < (3 * id->n_p)) { v = -up; }
    else if (kk < (4 * id->n_p)) { v = up; }
    else { /* between the pulses: no voltage */ }
    if (id->k < (2 * id->n_p)) { id->i_peak = fs_maxf(id->i_peak, fabsf(i.alpha)); }   /* L0 from the first ramp (+u_p from zero) */
    else if ((id->k >= (4 * id->n_p)) && (id->k < (6 * id->n_p))) { id->i_peak_b = fs_maxf(id->i_peak_b, fabsf(i.beta)); }
    else { /* the second halves: their peaks are the first ramps' with R and the dead time against them */ }
    const fs_ab u = (id->k < (4 * id->n_p)) ? (fs_ab){v, 0.0f} : (fs_ab){0.0f, v};
    if (++id->k < n_cycle) { ret = u; }
    else {
        /* the cycle is over */
        const float target = I_PROBE * c->i_max;
        if (id->i_peak >= (0.5f * target)) {
            id->L0 = id->u_p * (float)id->n_p * c->Ts / id->i_peak;   /* L di/dt = u, R and the dead time neglected */
            id->L0_min = (id->i_peak_b > 0.0f) ? fs_minf(id->L0, id->u_pb * (float)id->n_p * c->Ts / id->i_peak_b) : id->L0;
            id->sigma_i = 0.0f;
            ident_design_pi(id, id->L0, id->L0, 0.0f);
            ident_goto(id, FS_IDENT_AXIS);
            ret = u;
        }
        else {
            /* beta's current is alpha's times up to L_q / L_d (3.5 on zoo machine 48): its pulses stop growing
             * once it reaches the target (the next doubling could take it past i_max; the reluctance impulses
             * then cancel in part only), while alpha's grow on as they did alone (L0, which the carriers'
             * amplitudes are sized from, as it was) */
            const bool grow_b = (id->i_peak_b < target);
            if ((2.0f * id->u_p) <= (0.9f * id->u_max)) {
                id->u_p *= 2.0f;
                if (grow_b) { id->u_pb *= 2.0f; }
            } else if (id->n_p < 256) {
                id->n_p *= 2;
                if (!grow_b) { id->u_pb *= 0.5f; }   /* the same volt-seconds */
            } else {
                ident_fail(id, FS_IDQ_VERR, FS_IDR_NO_CURRENT);
            }
            id->k = 0;
            id->sub++;
            id->i_peak = 0.0f;
            id->i_peak_b = 0.0f;
            ret = u;
        }
    }
    return ret;
}

/* alpha current-controlled to i_ref, beta held at zero voltage: that short
 * circuit damps the rotor by its own EMF, and shows any motion as i_beta */
static fs_ab dc_on_alpha(fs_ident *id, fs_ab i, float i_ref)
{
    float u = pi_out(&id->pi_d, i_ref, i.alpha);
    float ur = fs_clampf(u, -0.95f * id->u_max, 0.95f * id->u_max);
    fs_pi_update(&id->pi_d, i_ref, i.alpha, u, ur);
    /* the short's current is held within I_SHORT by the loop's
     * proportional gain: a machine whose psi_f / L_q is above i_max
     * (zou2021: 52 A on 15) would otherwise trip while it swings */
    const float lim = I_SHORT * id->cfg.i_max;
    const float ub = -id->pi_d.cfg.k_p * (i.beta - fs_clamp_sym(i.beta, lim));
    return (fs_ab){ur, fs_clampf(ub, -0.95f * id->u_max, 0.95f * id->u_max)};
}

/* d current-controlled to i_ref, q to zero (coordinates of the standstill
 * frame, alpha its d): no torque on a rotor whose axis it is. Not the
 * short of ALIGN: there the dead time's q error (the error vector is up to
 * 30 deg off the current's) drives u_e / R_s through q, a torque that turns
 * a low-resistance rotor off the axis */
static fs_ab dc_on_d(fs_ident *id, fs_ab i, float i_ref)
{
    const float lim = 0.95f * id->u_max;
    const float u = pi_out(&id->pi_d, i_ref, i.alpha);
    const float ur = fs_clamp_sym(u, lim);
    fs_pi_update(&id->pi_d, i_ref, i.alpha, u, ur);
    const float lq = sqrtf(fs_maxf((lim * lim) - (ur * ur), 0.0f));
    const float v = pi_out(&id->pi_q, 0.0f, i.beta);
    const float vr = fs_clamp_sym(v, lq);
    fs_pi_update(&id->pi_q, 0.0f, i.beta, v, vr);
    return (fs_ab){ur, vr};
}

/* the ALIGN's short in a frame at angle th (the alignment's first direction) */
static fs_ab dc_in_frame(fs_ident *id, fs_ab i_ab, float i_ref, float th)
{
    const float ct = fs_cosf(th);
    const float st = fs_sinf(th);
    const fs_dq i = fs_park(i_ab, ct, st);
    const fs_ab u = dc_on_alpha(id, (fs_ab){i.d, i.q}, i_ref);
    return fs_inv_park((fs_dq){u.alpha, u.beta}, ct, st);
}

/* stationary quantities in the standstill frame (alpha = its d) */
static fs_ab to_frame(const fs_ident *id, fs_ab x)
{
    const fs_dq y = fs_park(x, fs_cosf(id->theta_s), fs_sinf(id->theta_s));
    return (fs_ab){y.d, y.q};
}

static fs_ab from_frame(const fs_ident *id, fs_ab x)
{
    return fs_inv_park((fs_dq){x.alpha, x.beta}, fs_cosf(id->theta_s), fs_sinf(id->theta_s));
}

static void acc_add(fs_ident *id, float u, fs_ab i)
{
    if (id->n_acc == 0) {
        id->u0 = u;
        id->i0 = i.alpha;
    }
    const float du = u - id->u0;
    const float di = i.alpha - id->i0;
    id->s_u += du;
    id->s_uu += du * du;
    id->s_i += di;
    id->s_ii += di * di;
    id->s_ib2 += i.beta * i.beta;
    id->n_acc++;
}

static float acc_std(float s, float ss, int n)
{
    const float m = s / (float)n;
    return sqrtf(fs_maxf(ss / (float)n - (m * m), 0.0f));
}

static void ldq_clear(fs_ident *id)
{
    id->k = 0;
    hf_clear(id);
}

/* complex arithmetic for AXIS's 2 x 2 phasor algebra */
typedef struct { float re; float im; } cx;
static cx cmul(cx a, cx b) { return (cx){(a.re * b.re) - (a.im * b.im), (a.re * b.im) + (a.im * b.re)}; }
static cx csub(cx a, cx b) { return (cx){a.re - b.re, a.im - b.im}; }
static cx cdiv(cx a, cx b)
{
    const float n = (b.re * b.re) + (b.im * b.im);
    return (cx){((a.re * b.re) + (a.im * b.im)) / n, ((a.im * b.re) - (a.re * b.im)) / n};
}
static cx ph(const float x[2][2][2], int j, int a) { return (cx){x[j][a][0], x[j][a][1]}; }

/* HF phasors of a cosine carrier's period position kk: cos, sin of its phase */
static void hf_phase(int kk, float *cu, float *su)
{
    const float phase = FS_TWO_PI * (float)kk / (float)N_HF;
    *cu = fs_cosf(phase);
    *su = fs_sinf(phase);
}

/* ---- AXIS: an HF voltage on alpha and on beta in turn, at zero current ----
 * The current loops hold both axes' mean current at zero (a carrier's
 * start leaves a dc current of its own size otherwise, which turns a
 * rotor off the axis) and answer the carrier too: from the two
 * injections' voltage and current phasors U, I (2 x 2, a column an
 * injection), the sampled R-L model i[k+1] - i[k] = Ts L^-1 (u[k-d] - R i[k])
 * gives
 *   M = e^{-j w Ts d} U I^-1 = L (e^{j w Ts} - 1) / Ts + R,
 * so L = Im(M) Ts / sin(w Ts) (R, and the dead time's error, in phase with
 * the current, only in Re). L = L_s - D [cos 2t, sin 2t; sin 2t, -cos 2t]
 * with L_s = (L_d + L_q)/2, D = (L_q - L_d)/2: the rotor's d axis t is its
 * low axis, modulo pi. No mean current; the carrier's torque has a mean
 * where it is neither on d nor on q (the reluctance torque of its own d
 * and q currents, 1.5 p (L_d - L_q) <i_d i_q>: 0.9 N m, near the Coulomb
 * friction, on zoo machine 14 at 0.3 i_max, which turned it 7 el.deg), of
 * opposite signs on alpha and beta. A torque +T, -T, +T, ... alternating
 * every tau leaves the rotor a mean speed T tau / (2 J) (its speed a
 * triangle that never goes below zero): 10 chunks of 12.5 ms on syre-thor
 * (J 0.0042 kg m^2, 0.76 N m at 45 el.deg) walk it 30 el.deg. The chunks
 * run in Walsh order A B B A (speed and angle both back to zero after each
 * four, the excursion at most T tau^2 / J: 2.3 el.deg there), after a
 * prelude A B B A of half length whose periods are not summed (the loops'
 * start). The hold loop answers the carrier period's mean current, not the
 * carrier: a PI on the sampled current answers the carrier too (its
 * k_p ~ 2 w_c L0 times the carrier's amplitude is beyond its clamp on a
 * machine whose probe L0 lies far above L_d) and its back-calculation
 * ratchets the integral each time it clips: 5 A of mean d current on
 * syre-thor, which repelled the magnet and turned the rotor 78 el.deg. */
static fs_ab step_axis(fs_ident *id, fs_ab i)
{
    fs_ab ret;
    const fs_ident_config *c = &id->cfg;
    /* sub 0..3: the prelude A B B A; then the summed chunks, also in Walsh order */
    const int s_ch = id->sub - 4;
    const int ax = (s_ch < 0) ? (((id->sub + 1) / 2) % 2) : (((s_ch + 1) / 2) % 2);   /* both >= 0 there */
    const int n_per = (s_ch < 0) ? AX_PRE : ((int)AX_SKIP + (int)AX_CHUNK);
    if ((id->k == 0) && (id->sub == 0)) {
        id->w_h = FS_TWO_PI / ((float)N_HF * c->Ts);
        id->U_h = fs_minf(I_HF_D * c->i_max * id->w_h * id->L0, 0.5f * id->u_max);
        for (int j = 0; j < 2; ++j) {
            for (int a = 0; a < 2; ++a) { id->ax_i[j][a][0] = 0.0f; id->ax_i[j][a][1] = 0.0f; id->ax_u[j][a][0] = 0.0f; id->ax_u[j][a][1] = 0.0f; }
            id->ax_hold[j] = 0.0f;
            id->ax_isum[j] = 0.0f;
        }
    }
    const int kh = id->k;
    float cu;
    float su;
    hf_phase(kh % N_HF, &cu, &su);
    fs_ab u;
    u.alpha = id->ax_hold[0] + ((ax == 0) ? (id->U_h * cu) : 0.0f);
    u.beta = id->ax_hold[1] + ((ax == 1) ? (id->U_h * cu) : 0.0f);
    id->ax_isum[0] += i.alpha;
    id->ax_isum[1] += i.beta;
    if ((kh % N_HF) == (N_HF - 1)) {
        /* the hold loop, once a carrier period on its mean current m: U = -K m with K N Ts / L = 1/2
         * (the period's mean moves by U N Ts / (2 L) within it: the loop's poles at |z| = 1/2 a period;
         * unstable beyond K N Ts / L = 2), L the probe's smaller: alpha's L0 alone is L_q where beta is on
         * d, 3.5 times beta's L on zoo machine 48, and its loop on beta swung to 1.1 i_max */
        const float K = 0.5f * id->L0_min / ((float)N_HF * c->Ts);
        const float lim = 0.45f * id->u_max;
        for (int a = 0; a < 2; ++a) {
            id->ax_hold[a] = fs_clamp_sym(-K * id->ax_isum[a] / (float)N_HF, lim);
            id->ax_isum[a] = 0.0f;
        }
    }
    if ((s_ch >= 0) && (kh >= (AX_SKIP * N_HF))) {
        id->ax_i[ax][0][0] += i.alpha * cu;
        id->ax_i[ax][0][1] -= i.alpha * su;
        id->ax_i[ax][1][0] += i.beta * cu;
        id->ax_i[ax][1][1] -= i.beta * su;
        id->ax_u[ax][0][0] += u.alpha * cu;
        id->ax_u[ax][0][1] -= u.alpha * su;
        id->ax_u[ax][1][0] += u.beta * cu;
        id->ax_u[ax][1][1] -= u.beta * su;
    }
    id->k++;
    if ((kh + 1) < (n_per * N_HF)) { ret = u; }   /* a whole number of periods: the carrier ends at zero current */
    else {
        id->k = 0;
        if (++id->sub < (4 + (2 * AX_TURNS))) { ret = u; }
        else {

            fs_ident_result *r = &id->res;
            const cx I00 = ph(id->ax_i, 0, 0);
            const cx I10 = ph(id->ax_i, 0, 1);
            const cx I01 = ph(id->ax_i, 1, 0);
            const cx I11 = ph(id->ax_i, 1, 1);
            const cx U00 = ph(id->ax_u, 0, 0);
            const cx U10 = ph(id->ax_u, 0, 1);
            const cx U01 = ph(id->ax_u, 1, 0);
            const cx U11 = ph(id->ax_u, 1, 1);
            const cx det = csub(cmul(I00, I11), cmul(I01, I10));
            if (!(((det.re * det.re) + (det.im * det.im)) > 0.0f)) {
                ident_fail(id, FS_IDQ_LD, FS_IDR_NO_CURRENT);
                ret = u;
            }
            else {
                const float wt = id->w_h * c->Ts;
                const float _Complex e = fs_cis(-wt * c->delay);
                const cx g = cdiv((cx){fs_cre(e) * c->Ts / fs_sinf(wt), fs_cim(e) * c->Ts / fs_sinf(wt)}, det);
                /* M = U I^-1, I^-1 = [I11, -I01; -I10, I00] / det */
                const float L_aa = cmul(g, csub(cmul(U00, I11), cmul(U01, I10))).im;
                const float L_ab1 = cmul(g, csub(cmul(U01, I00), cmul(U00, I01))).im;
                const float L_ba = cmul(g, csub(cmul(U10, I11), cmul(U11, I10))).im;
                const float L_bb = cmul(g, csub(cmul(U11, I00), cmul(U10, I01))).im;
                const float L_ab = 0.5f * (L_ab1 + L_ba);
                const float L_s = 0.5f * (L_aa + L_bb);
                const float D = sqrtf(0.25f * (L_aa - L_bb) * (L_aa - L_bb) + (L_ab * L_ab));
                r->L_d_axis = L_s - D;
                r->L_q_axis = L_s + D;
                r->saliency = 0.0f;
                if (L_s > 0.0f) { r->saliency = D / L_s; }
                if (!(r->L_d_axis > 0.0f) || !fs_fin(r->L_q_axis)) {
                    ident_fail(id, FS_IDQ_LD, FS_IDR_FIT);
                    ret = u;
                }
                else if (r->saliency < SAL_MIN) {   /* no axis to see standing: the rotor is turned to alpha */
                    ident_design_pi(id, r->L_d_axis, r->L_d_axis, 0.0f);
                    if (c->standstill_only && !c->locked) {
                        ident_fail(id, FS_IDQ_VERR, FS_IDR_NO_AXIS);
                    } else if (c->locked != 0) {   /* on alpha: R_s, the inverter's error and L (one value) need no axis; the map does */
                        id->theta_s = 0.0f;
                        r->theta_axis = 0.0f;
                        r->status[FS_IDQ_MAP] = FS_IDS_FAILED;
                        r->reason[FS_IDQ_MAP] = FS_IDR_NO_AXIS;
                        ident_goto(id, FS_IDENT_LEVELS);
                    } else {
                        ident_goto(id, FS_IDENT_ALIGN);
                    }
                    ret = (fs_ab){0.0f, 0.0f};
                }
                else {
                    ident_design_pi(id, r->L_d_axis, r->L_q_axis, 0.0f);
                    r->theta_hf = 0.5f * fs_atan2f(-2.0f * L_ab, -(L_aa - L_bb));
                    r->theta_axis = r->theta_hf;
                    id->theta_s = r->theta_hf;
                    /* the d sweep alone: R_s and the inverter's error not known yet (0: its ramp's voltage well above their
                     * drop); the nameplate's psi_f and J bound it where the free rotor would turn away */
                    const fs_mapid_config mc = {c->Ts, c->delay, c->i_max, r->L_d_axis, r->L_q_axis, 0.0f, 0.0f, c->pole_pairs,
                                                c->locked ? 0.0f : c->psi_f_hint, c->locked ? 0.0f : c->J_hint,
                                                (c->motion_max > 0.0f) ? c->motion_max : MOTION_MAX, id->w_c, 1, 0};
                    ident_goto(id, (fs_mapid_init(&id->map, &mc) == FS_OK) ? FS_IDENT_POLARITY : FS_IDENT_LEVELS);
                    ret = (fs_ab){0.0f, 0.0f};
                }
            }
        }
    }
    return ret;
}

/* ---- POLARITY: the map's d sweep on the axis: which end is the north ---- */
static fs_ab step_polarity(fs_ident *id, fs_ab i_ab)
{
    fs_ab ret;
    const fs_ident_config *c = &id->cfg;
    const float ct = fs_cosf(id->theta_s);
    const float st = fs_sinf(id->theta_s);
    const fs_dq u = fs_mapid_step(&id->map, fs_park(i_ab, ct, st), (fs_dq){0.0f, 0.0f}, id->u_max);
    if (id->map.stage != (int)FS_MAPID_DONE) { ret = fs_inv_park(u, ct, st); }
    else {
        fs_ident_result *r = &id->res;
        r->pol_asym = id->map.res.asym;
        r->pol_decided = id->map.res.decided;
        r->pol_flipped = id->map.res.flipped;
        r->pol_amp = id->map.res.d_amp;
        /* (the d sweep's axis offset, from its q flux, is not applied: before R_s and the inverter's error
         * are known the dead time's q part at the axis' angle puts up to 5 el.deg into it, zoo machine 12) */
        if (r->pol_flipped != 0) { id->theta_s = fs_wrap_pi(id->theta_s + FS_PI); }
        r->theta_axis = id->theta_s;
        /* read at +-i_max/2 only (the sweep stepped too coarsely at 3/4: a high link's U), a locked rotor's
         * polarity is left to MAP's full d sweep, which reads it at 3/4 and turns the frame where it
         * differs: near zero a PM-SyRM's ribs turn the asymmetry round (fs_mapid.c; syre-thor's locked map
         * came out mirrored, 39 % of psi_f off). LEVELS alternate meanwhile, as with no polarity; a free
         * rotor keeps it: its levels hold the magnet on the north it found */
        id->pol_known = r->pol_decided && !(c->locked && (id->map.res.pol_level < 0.7f));
        /* no polarity standing: where the rotor may turn, ALIGN pulls its north onto the axis (up to half a
         * turn); locked, the levels alternate. A free rotor that may not turn cannot take them: -I pushes
         * the magnet away, and on a salient rotor the reluctance torque of any d current turns its q axis
         * towards the current (the servo of tests/test_identify.py, 0.02 N m of friction: 12 turns) */
        if (!id->pol_known && c->standstill_only && !c->locked) {
            ident_fail(id, FS_IDQ_VERR, FS_IDR_NO_POLARITY);
            ret = (fs_ab){0.0f, 0.0f};
        }
        else {
            ident_goto(id, (!id->pol_known && !c->locked) ? FS_IDENT_ALIGN : FS_IDENT_LEVELS);
            ret = (fs_ab){0.0f, 0.0f};
        }
    }
    return ret;
}

/* ---- ALIGN: ramp to the alignment current over 0.2 s, hold until the rotor is still ----
 * (No saliency, or no polarity and the rotor may turn.) On alpha, where
 * the dead time's error vector of a current along phase a has no q part
 * (on any other axis it drives a q current of u_e / R_s through the short:
 * half the d current on zoo machine 1). The current 0.3 i_max, below half
 * of psi_f / (L_q - L_d) where the nameplate's psi_f and AXIS's inductances
 * give it (the magnet's pull then beats the reluctance torque's push). The
 * shorted q axis's current while the rotor creeps in
 * is at most the alignment current (its EMF p w psi_f against R balances
 * the torque), so the vector stays within i_max; the ramp is slower than a
 * small rotor's swing, so it creeps rather than swings. */
static fs_ab step_align(fs_ident *id, fs_ab i)
{
    fs_ab ret;
    const fs_ident_config *c = &id->cfg;
    const float dL = id->res.L_q_axis - id->res.L_d_axis;
    float I_top = I_ALIGN * c->i_max;
    if ((c->psi_f_hint > 0.0f) && (dL > 0.0f) && (id->res.saliency >= SAL_MIN)) { I_top = fs_minf(I_top, 0.5f * c->psi_f_hint / dL); }
    const float n_ramp_f = 0.2f / c->Ts;
    const int n_ramp = (int)n_ramp_f + 1;
    /* 20 ms windows (several swings of a small rotor), at least half the
     * swing's period where the nameplate's psi_f and J give it: a window
     * shorter than that can fall on a swing's turning point, the rotor
     * still for a moment (the Prius-like machine at 20 A swings at 5 Hz) */
    float t_win = 0.02f;
    if ((c->psi_f_hint > 0.0f) && (c->J_hint > 0.0f)) {
        const float p = (float)c->pole_pairs;
        const float K = 1.5f * p * I_top * (c->psi_f_hint - fs_maxf(dL, 0.0f) * I_top);   /* N m per el. rad */
        if (K > 0.0f) { t_win = fs_maxf(t_win, FS_PI / sqrtf(p * K / c->J_hint)); }
    }
    const int n_win = (int)(t_win / c->Ts) + 1;
    const float i_ref = I_top * fs_minf((float)id->k / (float)n_ramp, 1.0f);
    /* first on beta, then turned to alpha over the next ramp time: a rotor
     * that sits where the current points the other way (no torque, an
     * unstable rest) is pulled off it by the first direction */
    const int n_left = (3 * n_ramp) - id->k;
    const float th = 0.5f * FS_PI * fs_clamp01((float)n_left / (float)n_ramp);
    fs_ab u = (th > 0.0f) ? dc_in_frame(id, i, i_ref, th) : dc_on_alpha(id, i, i_ref);
    id->k++;
    if (id->k <= (3 * n_ramp)) { ret = u; }
    else {
        acc_add(id, u.alpha, i);
        if (id->n_acc < n_win) { ret = u; }
        else {
            /* still when i_q is within noise and 5 % of the current (a
             * low-resistance machine creeps into its last degrees for seconds,
             * its EMF over R_s a few percent of the current; harmless to the
             * levels, see below); at most 3 s */
            const float s_a = acc_std(id->s_i, id->s_ii, id->n_acc);
            const float rms_b = sqrtf(id->s_ib2 / (float)id->n_acc);
            /* against the sensors' noise (START's; a swing moves the d current too: its spread is not the noise) */
            const bool still = rms_b < ((0.03f * I_top) + (3.0f * ((id->res.noise_i > 0.0f) ? id->res.noise_i : s_a)));
            id->tries = still ? (id->tries + 1) : 0;
            if ((id->tries >= 2) && ((float)id->k * c->Ts) >= 0.3f) {   /* two windows in a row: not a swing's turning point */
                id->theta_s = 0.0f;
                id->res.theta_axis = 0.0f;   /* the rotor's north on alpha */
                id->aligned = 1;
                id->pol_known = 1;
                id->tries = 0;
                ident_goto(id, FS_IDENT_LEVELS);
            } else if (((float)id->k * c->Ts) > 3.0f) {
                ident_fail(id, FS_IDQ_VERR, FS_IDR_MOVED);
            } else {
                /* not yet still: wait on */
            }
            acc_clear(id);
            ret = u;
        }
    }
    return ret;
}

/* The leg error model's fit to E_j = U_j - R I_j: i_e on a log grid, u_e
 * by least squares; returns the rms residual. */
static float fit_leg_error(fs_ident *id, const float E[], const float I_j[])
{
    const float i_max = id->cfg.i_max;
    float best = INFINITY;
    for (int g = 0; g <= 40; ++g) {
        const float ie = 1e-3f * i_max * powf(10.0f, 2.5f * (float)g / 40.0f);   /* 1e-3 .. 0.3 i_max */
        float shh = 0.0f;
        float seh = 0.0f;
        float h[FS_IDENT_NLEV];
        for (int j = 0; j < FS_IDENT_NLEV; ++j) {
            const float I = I_j[j];
            /* d-axis current i on alpha: legs at i, -i/2, -i/2: E = 2/3 (g(i) + g(i/2)) */
            h[j] = (2.0f / 3.0f) * (I / sqrtf((I * I) + (ie * ie)) + (0.5f * I / sqrtf((0.25f * I * I) + (ie * ie))));
            shh += h[j] * h[j];
            seh += E[j] * h[j];
        }
        const float ue = seh / shh;
        float sr = 0.0f;
        for (int j = 0; j < FS_IDENT_NLEV; ++j) { sr += (E[j] - (ue * h[j])) * (E[j] - (ue * h[j])); }
        if (sr < best) {
            best = sr;
            id->res.u_e = ue;
            id->res.i_e = ie;
        }
    }
    return sqrtf(best / (float)FS_IDENT_NLEV);
}

/* The levels' top current: i_test (0.6 i_max unless given), on the north
 * pole at most half of psi_f / (L_q - L_d) (the nameplate's psi_f, AXIS's
 * inductances): below that bound the magnet's pull on an aligned rotor
 * beats the reluctance torque's push at half its strength; a locked rotor
 * needs no bound. */
static float level_top(const fs_ident *id)
{
    const fs_ident_config *c = &id->cfg;
    float I = (c->i_test > 0.0f) ? c->i_test : (I_TEST * c->i_max);
    const float dL = id->res.L_q_axis - id->res.L_d_axis;
    if (id->pol_known && !c->locked && (c->psi_f_hint > 0.0f) && (dL > 0.0f) && (id->res.saliency >= SAL_MIN)) {
        I = fs_minf(I, 0.5f * c->psi_f_hint / dL);
    }
    return I;
}

/* The q loop's bandwidth while a level on d is measured: a fifth of the
 * rotor's swing frequency about the level, w_n^2 = p K / J with K = 1.5 p I
 * (psi_f - (L_q - L_d) I) N m per el. rad (the magnet's pull less the
 * reluctance's push, the nameplate's psi_f and J). A q loop at the drive's
 * bandwidth w_c holds i_q at zero against the swing's EMF, so nothing damps
 * the frictionless rotor: it swings about the level for the whole step
 * (examples/own-machine: +-3 el.deg at 18 A, 1.2 rad/s), and at the end of
 * LEVELS, the current gone, the speed it has then is a drift (0.6 rad/s:
 * 30 el.deg through LDQ and CHECK). Below the swing frequency the slow
 * loop's impedance R + 2 w_s L_q passes the EMF's swing as a q current,
 * a torque against the speed: B = 1.5 p^2 psi_f^2 / (R + 2 w_s L_q)
 * (damping ratio 1.1 on own, 1.4 on syre-thor at its top level), while its
 * integral, learned at w_c through the level's settling, keeps the dead
 * time's dc q error out. 0 where the nameplate gives no psi_f or J (w_c). */
static float level_q_bw(const fs_ident *id, float I)
{
    const fs_ident_config *c = &id->cfg;
    float ret = 0.0f;
    if ((c->psi_f_hint > 0.0f) && (c->J_hint > 0.0f) && !c->locked) {
        const float p = (float)c->pole_pairs;
        const float dL = fs_maxf(id->res.L_q_axis - id->res.L_d_axis, 0.0f);
        const float K = 1.5f * p * fabsf(I) * (c->psi_f_hint - (dL * fabsf(I)));
        if (K > 0.0f) { ret = fs_minf(0.2f * sqrtf(p * K / c->J_hint), id->w_c); }
    }
    return ret;
}

/* the q loop redesigned at bandwidth bw (its integral kept: the voltage it has learned) */
static void q_loop_bw(fs_ident *id, float bw)
{
    const float integ = id->pi_q.integ;
    const float L = (id->res.L_q_axis > 0.0f) ? id->res.L_q_axis : id->L0;
    (void)fs_pi_design_init(&id->pi_q, id->cfg.Ts, L, 0.0f, bw, (id->u_max > 0.0f) ? id->u_max : 1.0f);
    id->pi_q.integ = integ;
}

/* ---- LEVELS: each level settles (30 loop time constants), then is averaged ----
 * On the axis, each level at +I then -I (sub 2 j, 2 j + 1): the magnet's
 * torque on a rotor a little off the axis alternates with them, and half
 * the difference of the two voltages is free of what does not change
 * sign (the sensors' offsets, the error's even part). After ALIGN (no
 * saliency: the rotor held on the axis by the current itself) +I only:
 * -I would push the magnet away. */
static fs_ab step_levels(fs_ident *id, fs_ab i_ab)
{
    fs_ab ret;
    const fs_ident_config *c = &id->cfg;
    const bool alt = !id->pol_known;
    const int j = alt ? (id->sub / 2) : id->sub;
    const float sgn = (alt && (id->sub & 1)) ? -1.0f : 1.0f;
    if ((id->sub == 0) && (id->k == 0)) { id->res.i_level_top = level_top(id); }
    const float i_test = id->res.i_level_top;
    const float t_top = (c->t_level > 0.0f) ? c->t_level : T_LEVEL;
    const float I_ref = sgn * LEV_FRAC[j] * i_test;
    const float n_set_f = 30.0f / (id->w_c * c->Ts);
    const int n_set = (int)n_set_f + 1;
    /* the three levels R_s comes from (its slope is the small difference
     * of large voltages) the longer window, the rest half of it; one
     * sign alone twice as long */
    const float n_meas_f = ((j < 3) ? 1.0f : 0.5f) * (alt ? 1.0f : 2.0f) * t_top / c->Ts;
    const int n_meas = (int)n_meas_f + 1;
    const fs_ab i = to_frame(id, i_ab);
    const fs_ab u = id->aligned ? dc_on_alpha(id, i, I_ref) : dc_on_d(id, i, I_ref);
    id->k++;
    if (id->k <= n_set) {
        if (id->k == 1) { id->q_set = 0.0f; }
        if (id->k > (n_set - (n_set / 2))) { id->q_set += u.beta; }
        ret = from_frame(id, u);
    }
    else {
        if ((id->n_acc == 0) && !id->aligned && (j >= 3)) {   /* settled: the q loop slowed to damp the swing (level_q_bw) */
            const float bw = level_q_bw(id, I_ref);
            if (bw > 0.0f) {
                q_loop_bw(id, bw);
                /* its integral from the q voltage's mean over the settling's second half: the fast loop's
                 * integral at one sample carries the current's noise times its gain (4 mV on own, 0.1 A
                 * of q current through the slow loop's 0.04 ohm, a kick of 0.3 rad/s) */
                const int n_half = n_set / 2;
                id->pi_q.integ = id->q_set / (float)n_half;
            }
        }
        acc_add(id, u.alpha, i);
        id->e_abs += u.beta;
        /* batch means of u: the loop's noise is correlated from sample to
         * sample, so the noise of the mean comes from the batches' spread */
        const int n_b = n_meas / FS_IDENT_NBATCH;
        if (((id->n_acc % n_b) == 0) && ((id->n_acc / n_b) <= FS_IDENT_NBATCH)) {
            id->batch[(id->n_acc / n_b) - 1] = id->s_u;   /* running sums; differenced below */
        }
        if (id->n_acc < n_meas) { ret = from_frame(id, u); }
        else {
            const int n = id->n_acc;
            fs_ident_result *r = &id->res;
            const float I_m = id->i0 + (id->s_i / (float)n);
            const float U_m = id->u0 + (id->s_u / (float)n);
            if (sgn > 0.0f) {
                r->I_lev[j] = I_m;
                r->U_lev[j] = U_m;
            } else {
                r->I_levn[j] = I_m;
                r->U_levn[j] = U_m;
            }
            const float s_a = acc_std(id->s_i, id->s_ii, n);
            const float s_u = acc_std(id->s_u, id->s_uu, n);
            const float rms_b = sqrtf(id->s_ib2 / (float)n);
            /* moved: after ALIGN (q shorted), a q current of a tenth of the level. A
             * rotor creeping into its last degree against Coulomb friction drives a
             * few percent through the shorted q axis of a low-resistance machine
             * (its EMF over R_s) but puts no voltage on d; a turning one drives the
             * level's order. On the axis (q held at zero), a q voltage beyond the
             * dead time's q part (at most tan 30 deg of its d part, within the
             * level's voltage): a back-EMF */
            const float uq_m = id->e_abs / (float)n;
            if (id->aligned ? rms_b > 0.1f * fabsf(I_ref) + (4.0f * s_a) + (0.01f * c->i_max)
                            : fabsf(uq_m) > 0.7f * fabsf(U_m) + (4.0f * s_u) + (0.01f * id->u_max)) {
                r->i_moved = I_ref;
                ident_fail(id, FS_IDQ_VERR, FS_IDR_MOVED);
                ret = from_frame(id, u);
            }
            else {
                if (j < 3) {   /* the noise of a level's mean voltage, from the top levels */
                    id->sigma_i = fs_maxf(id->sigma_i, s_a);
                    float prev = 0.0f;
                    float sb = 0.0f;
                    float sbb = 0.0f;
                    for (int b = 0; b < FS_IDENT_NBATCH; ++b) {
                        const float m = (id->batch[b] - prev) / (float)(n_meas / FS_IDENT_NBATCH);
                        prev = id->batch[b];
                        sb += m;
                        sbb += m * m;
                    }
                    const float s_mean = acc_std(sb, sbb, FS_IDENT_NBATCH) / sqrtf((float)(FS_IDENT_NBATCH - 1));
                    r->snr_rs = fs_maxf(r->snr_rs, fs_maxf(s_mean, s_u / (float)n));   /* held here as that noise, V */
                }
                id->k = 0;
                acc_clear(id);
                if (!id->aligned) { q_loop_bw(id, id->w_c); }   /* the next level's dc q error learned at full bandwidth */
                if (++id->sub < (alt ? 2 : 1) * FS_IDENT_NLEV) { ret = from_frame(id, u); }
                else {

                    /* each level's current and voltage: half the difference of the signs' */
                    float I_j[FS_IDENT_NLEV];
                    float U_j[FS_IDENT_NLEV];
                    for (int k = 0; k < FS_IDENT_NLEV; ++k) {
                        I_j[k] = alt ? 0.5f * (r->I_lev[k] - r->I_levn[k]) : r->I_lev[k];
                        U_j[k] = alt ? 0.5f * (r->U_lev[k] - r->U_levn[k]) : r->U_lev[k];
                    }
                    /* R_s: least squares through the top three levels */
                    float mi = 0.0f;
                    float mu = 0.0f;
                    float sii = 0.0f;
                    float siu = 0.0f;
                    for (int k = 0; k < 3; ++k) {
                        mi += I_j[k] / 3.0f;
                        mu += U_j[k] / 3.0f;
                    }
                    for (int k = 0; k < 3; ++k) {
                        sii += (I_j[k] - mi) * (I_j[k] - mi);
                        siu += (I_j[k] - mi) * (U_j[k] - mu);
                    }
                    r->R_s = siu / sii;
                    const float span = r->R_s * (I_j[0] - I_j[2]);
                    const float mid = U_j[1] - (mu + (r->R_s * (I_j[1] - mi)));
                    /* the noise of a level's voltage: the sign's, or of half a difference */
                    const float noise = alt ? (r->snr_rs * FS_INV_SQRT3 * 1.2247449f) : r->snr_rs;   /* x sqrt(2)/2 */
                    r->r_fit_rs = fabsf(mid) / fs_maxf(fabsf(span), 1e-30f);
                    r->snr_rs = fabsf(span) / fs_maxf(noise, 1e-30f);
                    float E[FS_IDENT_NLEV];
                    for (int k = 0; k < FS_IDENT_NLEV; ++k) { E[k] = U_j[k] - (r->R_s * I_j[k]); }
                    const float resid = fit_leg_error(id, E, I_j);
                    /* the error model within a tenth of its size, or within the noise (and
                     * float's resolution of the level voltages: an ideal inverter's is 0) */
                    if (resid > 0.1f * fabsf(r->u_e) + (5.0f * noise) + (1e-4f * id->u_max)) {
                        ident_fail(id, FS_IDQ_VERR, FS_IDR_FIT);
                        ret = from_frame(id, u);
                    }
                    else {
                        ident_ok(id, FS_IDQ_VERR);
                        if (!(r->R_s > 0.0f)) {
                            ident_fail(id, FS_IDQ_RS, FS_IDR_FIT);
                        } else if (r->snr_rs < 30.0f) {   /* the slope's noise below 3 %/ (2 sigma) */
                            ident_fail(id, FS_IDQ_RS, FS_IDR_LOW_SIGNAL);
                        } else if (r->r_fit_rs > 0.03f) {  /* the middle level off the line by 3 % of the span: the error is not flat there */
                            ident_fail(id, FS_IDQ_RS, FS_IDR_FIT);
                        } else {
                            ident_ok(id, FS_IDQ_RS);
                            ident_goto(id, FS_IDENT_LDQ);
                        }
                        ret = from_frame(id, u);
                    }
                }
            }
        }
    }
    return ret;
}

/* L of a sampled R-L branch from its voltage and current phasors at w Ts:
 * i[k+1] = a i[k] + b u[k - d] gives (U/I) z^-d = (z - a)/b, so
 * b = sin(w Ts)/Im(W), a = cos(w Ts) - b Re(W); the dead time, in phase
 * with the current, adds to Re(W) only. */
static float hf_inductance(const fs_ident *id, float Ur, float Ui, float Ir, float Ii)
{
    float ret;
    const float Ts = id->cfg.Ts;
    const float wt = id->w_h * Ts;
    const float d = id->cfg.delay;
    const float den = (Ir * Ir) + (Ii * Ii);
    if (!(den > 0.0f)) { ret = NAN; }
    else {
        const float Yr = ((Ur * Ir) + (Ui * Ii)) / den;
        const float Yi = ((Ui * Ir) - (Ur * Ii)) / den;
        const float cd = fs_cosf(wt * d);
        const float sd = fs_sinf(wt * d);
        const float Wr = (Yr * cd) + (Yi * sd);                               /* W = Y e^{-j w Ts d} */
        const float Wi = (Yi * cd) - (Yr * sd);
        if (!(Wi > 0.0f)) { ret = NAN; }
        else {
            const float b = fs_sinf(wt) / Wi;
            const float a = fs_cosf(wt) - (b * Wr);
            if ((a > 0.0f) && (a < 0.999f)) { ret = (1.0f - a) * Ts / (-logf(a) * b); }   /* L = R Ts / x, R = (1 - a)/b, x = -ln a */
            else {
                ret = Ts / b;
            }
        }
    }
    return ret;
}

/* Frame current control at i_ref: PI per axis with the cross-coupling fed
 * forward; the voltage is turned to the middle of the period it acts in and
 * held within the linear range. */
static fs_ab frame_current(fs_ident *id, fs_ab i_ab, fs_dq i_ref)
{
    const fs_ident_result *r = &id->res;
    const float ct = fs_cosf(id->theta);
    const float st = fs_sinf(id->theta);
    const fs_dq i = fs_park(i_ab, ct, st);
    const float ff_d = -id->w * r->L_q * i.q;
    const float ff_q = id->w * r->L_d * i.d;
    const float vd = pi_out(&id->pi_d, i_ref.d, i.d);
    const float vq = pi_out(&id->pi_q, i_ref.q, i.q);
    float ud = vd + ff_d;
    float uq = vq + ff_q;
    const float m = sqrtf((ud * ud) + (uq * uq));
    const float lim = 0.95f * id->u_max;
    if (m > lim) {
        ud *= lim / m;
        uq *= lim / m;
    }
    fs_pi_update(&id->pi_d, i_ref.d, i.d, vd, ud - ff_d);
    fs_pi_update(&id->pi_q, i_ref.q, i.q, vq, uq - ff_q);
    id->u_dq = (fs_dq){ud, uq};
    const float th = id->theta + (id->w * id->cfg.Ts * (id->cfg.delay + 0.5f));
    return fs_inv_park(id->u_dq, fs_cosf(th), fs_sinf(th));
}

/* The back-EMF in the frame from the voltage equation in steady state,
 * less the inverter's error at the sampled currents. */
static fs_dq frame_emf(const fs_ident *id, fs_ab i_ab)
{
    const fs_ident_result *r = &id->res;
    const float ct = fs_cosf(id->theta);
    const float st = fs_sinf(id->theta);
    const fs_dq i = fs_park(i_ab, ct, st);
    const fs_dq ue = fs_park(ident_inv_error(id, i_ab, id->u_prev[(id->cfg.delay > 0.0f) ? 1 : 0]), ct, st);
    return (fs_dq){id->u_dq.d - ue.d - (r->R_s * i.d) + (id->w * r->L_q * i.q),
                   id->u_dq.q - ue.q - (r->R_s * i.q) - (id->w * r->L_d * i.d)};
}

/* The PLL on the EMF: the frame's d axis onto the magnet's (e on +q). */
static float frame_pll(fs_ident *id, fs_ab i_ab)
{
    const fs_dq e = frame_emf(id, i_ab);
    const float phi = fs_atan2f(-e.d, e.q) * ((id->w >= 0.0f) ? 1.0f : -1.0f);
    const float kp = 2.0f * id->bw_pll;                                 /* double pole at bw_pll */
    const float ki = id->bw_pll * id->bw_pll;
    id->w0 += ki * phi * id->cfg.Ts;                                       /* w0: the integral, the speed */
    id->w = id->w0 + (kp * phi);
    id->theta = fs_wrap_pi(id->theta + (id->w * id->cfg.Ts));
    return phi;
}

/* ---- LDQ: HF on d at zero current, then on q at two d biases (frame: theta_s) ----
 * On q, a d bias keeps the two legs that carry the carrier off zero, where
 * the dead time's error flips: with it constant the carrier sees none of
 * it (at zero bias it was of the carrier's own size on high links and low
 * L, and its quadrature part, from the ripple's timing, put up to 5 % into
 * L_q). Two biases give L_q's change with i_d and L_q at zero current: on
 * the north pole I_b and 2 I_b, extrapolated (a negative d current would
 * push the magnet away: a free rotor without friction turns); the
 * polarity unknown, +I_b and -I_b, their mean (the torque a misalignment
 * makes with the magnet alternating with them). I_b clears the
 * carrier's peak on those legs (sqrt 3 i_h) and six knees of the fitted
 * error. On d the carrier rides on the biased leg itself, whose ripple
 * still crosses zero on low-L machines (+5 to +9 % at a bias): d is
 * measured at zero current, where the error's fundamental is mostly in
 * phase with the current. Its cross response shows how far the rotor's
 * axis is off the frame: the frame is turned onto it. CHECK is the d
 * measurement alone, at the end of the standstill steps. */
static float ldq_bias(const fs_ident *id, int level)
{
    const float i_max = id->cfg.i_max;
    float I_b = fs_clampf((FS_SQRT3 * I_HF * i_max) + (6.0f * id->res.i_e), 0.2f * i_max, 0.4f * i_max);
    /* on the north pole I_b and 2 I_b within the levels' bound (the carrier's clearance given up first:
     * a negative bias there would push the magnet away); else +-I_b */
    /* a locked rotor at +-I_b whatever its polarity: their mean is L_q at zero to the curve's second order,
     * where the extrapolation through I_b and 2 I_b is first order in a bend near zero (the Baldor PM-SyRM's
     * L_q peaks at +5 A: 145 and 133 mH at 5.6 and 11.2 A read 158 at zero, +12 %, the truth 141; the mean at
     * +-5.6 A, 139) */
    const bool north = (id->aligned || id->pol_known) && !id->cfg.locked;
    if (north) { I_b = fs_minf(I_b, 0.5f * id->res.i_level_top); }
    /* a locked rotor also at +-2 I_b: the mean at +-I_b is L_q at zero to the curve's second order, and the
     * two means together take that order out (ldq_lq) */
    static const float LOCKED[4] = {1.0f, -1.0f, 2.0f, -2.0f};
    float ret;
    if (id->cfg.locked != 0) { ret = LOCKED[level & 3] * I_b; }
    else { ret = (level == 0) ? I_b : (north ? 2.0f : -1.0f) * I_b; }
    return ret;
}

/* LDQ's q passes: two biases, or four on a locked rotor (ldq_bias) */
static int ldq_n_bias(const fs_ident *id) { return (id->cfg.locked != 0) ? 4 : 2; }

/* L_q at zero current and its change with i_d from the biases' readings.
 * Two: the line through them (on the north pole I_b, 2 I_b: extrapolated;
 * +-I_b: their mean). Four on a locked rotor (+-I_b, +-2 I_b): the means
 * m1, m2 of the pairs are L_q(0) + c I^2 and L_q(0) + 4 c I^2 for a curve
 * even to its second order, so (4 m1 - m2) / 3 (Richardson's): SyR-e's
 * THOR, whose L_q is 30.0 mH at -17.6 A of d current, 33.9 at zero and
 * 33.4 at +17.6 A (the ribs the magnet saturates), read -6.5 % by the mean
 * at the +-17.6 A its inverter's error asks, -2.9 % so. */
static void ldq_lq(fs_ident_result *r, int n_bias)
{
    r->dL_q = (r->L_q_bias[1] - r->L_q_bias[0]) / (r->I_bias[1] - r->I_bias[0]);
    r->L_q = r->L_q_bias[0] - (r->I_bias[0] * r->dL_q);
    if (n_bias == 4) {
        const float m2 = 0.5f * (r->L_q_bias[2] + r->L_q_bias[3]);
        r->L_q = ((4.0f * r->L_q) - m2) / 3.0f;
    }
}

/* The rotor's axis against the frame's from the cross response r (the
 * in-phase ratio of the q current to the d current under a d carrier):
 * r = g sin 2e / (1 + g cos 2e) with g the saliency (L_q - L_d)/(L_q + L_d). */
static float axis_offset(float r, float g)
{
    float ret;
    /* below AXIS's saliency threshold the cross response holds no axis, only its noise over g (the
     * siemens-1ft6084 at g = 0.004: a 1.6 el.deg turn of the frame ALIGN had put on the magnet) */
    if (!(g >= SAL_MIN)) { ret = 0.0f; }
    else {
        const float s = fs_clampf(r / (g * sqrtf(1.0f + (r * r))), -1.0f, 1.0f);
        ret = 0.5f * (fs_atanf(r) + asinf(s));
    }
    return ret;
}

static fs_ab step_ldq(fs_ident *id, fs_ab i_ab)
{
    const fs_ident_config *c = &id->cfg;
    const bool check = id->step == (int)FS_IDENT_CHECK;
    const float n_set_f = 30.0f / (id->w_c * c->Ts);
    const int n_set = (int)n_set_f + 1;
    /* sub 0: d at zero current (its cross response turns the frame onto the rotor's axis before the
     * q carrier: L_q measured on a frame 1.4 el.deg off read -2 % on zoo machine 12); 1, 2: q at the first
     * and second bias */
    const bool d_meas = check || (id->sub == 0);
    const int axis = d_meas ? (int)0 : (int)1;
    const int level = id->sub - 1;
    float I_b = d_meas ? 0.0f : ldq_bias(id, level);
    /* CHECK after MAP on a free rotor whose north is known: the d carrier at zero current turns a salient
     * rotor's d axis away from itself (its mean reluctance torque, -1.5 p (L_q - L_d) I_h^2 / 4 sin 2 delta
     * for the frame delta off the rotor's axis, an inverted pendulum: the frictionless H27 from 5 to 148
     * el.deg in it, and the I/f spin that starts on the axis CHECK read lost the rotor: psi_f, J failed); a
     * d bias I_b on the north holds it with the magnet's 1.5 p psi_f I_b sin delta: four times the
     * (L_q - L_d) I_h^2 / (2 psi_f) that balances the push (the nameplate's psi_f; far below the carrier,
     * whose crossing of zero the d measurement wants), then back to zero before the spin. Not in the CHECK
     * before MAP: there the pendulum it leaves swings through CHECK's window (the own machine's 130 ms
     * against 90 ms), the offset read is the swing's mean, and MAP's d sweep began 3 el.deg off the rotor
     * (its map 9.3 % of psi_f off against 4.6 %) */
    const float dL = id->res.L_q - id->res.L_d;
    if (check && (id->res.status[FS_IDQ_MAP] != (int)FS_IDS_PENDING) && id->pol_known && !c->locked && (c->psi_f_hint > 0.0f)
        && (dL > 0.0f)) {
        const float I_h = I_HF_D * c->i_max;
        const float I_s = 4.0f * dL * I_h * I_h / (2.0f * c->psi_f_hint);
        /* within the levels' bound (half of psi_f / (L_q - L_d): beyond, the bias' own reluctance torque
         * pushes too); where the push needs more, none (the Prius MG2: 78 A against 10) */
        if (I_s <= (0.5f * id->res.i_level_top)) { I_b = I_s; }
    }
    const bool ld_read = d_meas && !check;   /* LDQ's own d carrier: L_d */
    if (ld_read && !(id->hf_scale > 0.0f)) { id->hf_scale = 1.0f; }
    if (id->k == 0) {
        id->w_h = FS_TWO_PI / ((float)N_HF * c->Ts);
        const float R = id->res.R_s;                         /* the probe's L: the amplitudes B-IDENT was tuned on */
        const float X = id->w_h * id->L0;
        /* LDQ's d carrier scaled after the voltage's bound (which holds a high-impedance axis' carrier below
         * its I_HF_D i_max: the THOR's at 4.1 A): each pass' current the last's times the scale's change */
        id->U_h = fs_minf((axis ? I_HF : I_HF_D) * c->i_max * sqrtf((R * R) + (X * X)), 0.5f * id->u_max)
                  * (ld_read ? id->hf_scale : 1.0f);
        ldq_clear(id);
    }
    const fs_ab i = to_frame(id, i_ab);
    const bool holding = check && (id->sub == 3);   /* CHECK's holding bias back to zero, settled, before MAP or SPIN start from zero */
    const bool settling = !holding && (id->k < n_set);   /* each injection starts from a settled bias */
    const float I_dc = holding ? 0.0f : I_b;
    fs_ab u = id->aligned ? dc_on_alpha(id, i, I_dc) : dc_on_d(id, i, I_dc);   /* the bias on d, q at zero (shorted after ALIGN) */
    if (holding || settling) {
        id->k++;
        if (holding && (id->k >= n_set)) {
            int next = FS_IDENT_SPIN;
            if (id->res.status[FS_IDQ_MAP] == (int)FS_IDS_PENDING) {
                next = FS_IDENT_MAP;
            } else if ((c->standstill_only != 0) || (c->locked != 0)) {
                next = FS_IDENT_DONE;
            } else {
                /* the free rotor's spin */
            }
            ident_goto(id, next);
            u.alpha = 0.0f;
            u.beta = 0.0f;
        }
        return from_frame(id, u);
    }
    const int kh = id->k - n_set;
    float cu;
    float su;
    hf_phase(kh % N_HF, &cu, &su);
    /* a cosine voltage: the inductive current starts at its own zero. Its first sample and one after its last
     * at half (a trapezoidal start and end): the held samples' flux U Ts sum cos(2 pi k / N) from a whole
     * first sample has a mean of U Ts / 2, and ends there: a dc current U Ts / (2 L) = 0.31 of the
     * carrier's amplitude that the q short after ALIGN keeps, decaying at L / R only; when the bias then
     * fell to zero it was torque, 0.39 A on the frictionless H27, 1.1 rad/s and 35 el.deg through CHECK
     * (now 0.14 A and 15 el.deg: the rest is the R-L transient's) */
    const bool trap = id->aligned && (axis == 1);   /* only there: elsewhere the axis' current loop takes the dc out */
    const int n_tot = (((int)HF_SKIP + (int)HF_MEAS) * (int)N_HF) - (trap ? 0 : 1);
    const float uh = id->U_h * cu * ((trap && ((kh == 0) || (kh == n_tot))) ? 0.5f : 1.0f);
    if (axis == 0) { u.alpha += uh; } else { u.beta += uh; }
    const float ua = (axis == 0) ? u.alpha : u.beta;   /* all of the axis' voltage: the bias loop answers the carrier too */
    if ((kh >= (HF_SKIP * N_HF)) && (kh < ((HF_SKIP + HF_MEAS) * N_HF))) {
        /* phasors X = sum x[k] e^{-j w k Ts}: the current sampled now, the reference of now */
        id->hf_u[0] += ua * cu;
        id->hf_u[1] -= ua * su;
        id->hf_i[0][0] += i.alpha * cu;
        id->hf_i[0][1] -= i.alpha * su;
        id->hf_i[1][0] += i.beta * cu;
        id->hf_i[1][1] -= i.beta * su;
        if (ld_read) {   /* the second harmonic: cos 2x = c^2 - s^2, sin 2x = 2 s c */
            const float ia = (axis == 0) ? i.alpha : i.beta;
            id->hf_i2[0] += ia * ((cu * cu) - (su * su));
            id->hf_i2[1] -= ia * (2.0f * su * cu);
        }
    }
    id->k++;
    if (kh < n_tot) { return from_frame(id, u); }   /* through kh = n_tot: the closing half sample */

    fs_ident_result *r = &id->res;
    const int n = HF_MEAS * N_HF;
    const float *Iax = id->hf_i[axis];
    const float *Ix = id->hf_i[1 - axis];
    const float L = hf_inductance(id, id->hf_u[0], id->hf_u[1], Iax[0], Iax[1]);
    /* amplitude 2|I|/n against the noise sigma sqrt(2/n) of that estimate */
    const float amp = 2.0f * sqrtf((Iax[0] * Iax[0]) + (Iax[1] * Iax[1])) / (float)n;
    const float snr = amp / fs_maxf(id->sigma_i * sqrtf(2.0f / (float)n), 1e-6f * c->i_max);
    const int q = check ? (int)FS_IDQ_MAP : (axis == 0) ? (int)FS_IDQ_LD : (int)FS_IDQ_LQ;
    if (!check) { r->snr_l = (id->sub == 0) ? snr : fs_minf(r->snr_l, snr); }
    if (!(L > 0.0f) || !fs_fin(L)) {
        ident_fail(id, q, FS_IDR_FIT);
        return from_frame(id, u);
    }
    if (snr < 100.0f) {   /* 1 % of the amplitude at one sigma: L_q's extrapolation doubles the noise */
        ident_fail(id, q, FS_IDR_LOW_SIGNAL);
        return from_frame(id, u);
    }
    if (ld_read) {
        /* L_d is the incremental inductance at zero current; the carrier reads the fundamental of its swing,
         * +-I_HF_D i_max. Where the axis' flux is lopsided over that swing (syre-thor: the incremental L_d
         * 5.0 mH below zero current, 7.6 mH at +1..2 A, 16 mH at +4..9 A, the ribs the magnet saturates
         * freed by a d current adding to it) the fundamental is not the value at zero (7.2 mH at +-6.6 A,
         * the drive read 5.76, +15 %); the current's second harmonic shows the lopsidedness (an even part
         * of L(i) over the swing: none on a symmetric axis, whose saturation and dead time make odd ones).
         * Above H2_MAX of the fundamental the carrier is halved and the reading taken again, at most
         * four times (LD_S_MIN) and while the halved carrier keeps twice the SNR the check above asks: the
         * THOR's 6.6 A gives 0.24 (current-driven), 3.3 A 0.11, 1.65 A 0.04 (L 5.2 mH, +3 %) */
        const float h2 = 2.0f * sqrtf((id->hf_i2[0] * id->hf_i2[0]) + (id->hf_i2[1] * id->hf_i2[1])) / (float)n / amp;
        /* the limit as the swing shrinks: another pass only while the last one moved L by more than L_CONV
         * (a kink at zero current itself, the Baldor's map, its slopes either side of zero apart at any swing,
         * keeps its second harmonic but not its L: one pass more, where each costs a free rotor time to
         * drift, the Baldor's 8.7 el.deg through five, past the 8 its alignment allows) */
        const bool moving = !(id->ld_L_prev > 0.0f) || (fabsf(L - id->ld_L_prev) > (L_CONV * L));
        id->ld_L_prev = L;
        r->ld_h2 = h2;
        r->ld_carrier = amp;
        const float s_min = LD_S_MIN;
        if ((h2 > H2_MAX) && moving && (id->hf_scale > (s_min + 1e-6f)) && (snr >= 400.0f)) {
            /* to where a lopsidedness proportional to the swing (a smooth L(i)) would leave H2_MAX, a quarter
             * at least and a half at most a pass, within the SNR (twice the check's at the carrier's current) */
            const float f = fs_clampf(H2_MAX / h2, 0.25f, 0.5f);
            id->hf_scale = fs_maxf(fs_maxf(id->hf_scale * f, s_min), id->hf_scale * 200.0f / snr);
            ldq_clear(id);
            return from_frame(id, u);
        }
    }
    if (d_meas) {
        /* the cross response's in-phase part: the rotor's axis against the frame's */
        const float den = (Iax[0] * Iax[0]) + (Iax[1] * Iax[1]);
        const float e = axis_offset(((Ix[0] * Iax[0]) + (Ix[1] * Iax[1])) / den, r->saliency);
        id->theta_s = fs_wrap_pi(id->theta_s + e);   /* onto the rotor's axis */
        if (check && (r->status[FS_IDQ_MAP] == (int)FS_IDS_PENDING)) {   /* before MAP: the frame onto the axis the biases left */
            r->motion_premap = e;
            if (I_b != 0.0f) {   /* its holding bias back to zero first: MAP's d sweep reads its first zero at the start */
                id->sub = 3;
                id->k = 0;
                return from_frame(id, u);
            }
            ident_goto(id, FS_IDENT_MAP);
            return (fs_ab){0.0f, 0.0f};
        }
        if (check) {
            r->motion_check = e;
            if (I_b != 0.0f) {
                id->sub = 3;
                id->k = 0;
            } else {
                ident_goto(id, (c->standstill_only || c->locked) ? FS_IDENT_DONE : FS_IDENT_SPIN);
            }
            id->i_if = I_IF * c->i_max;
            id->theta = id->theta_s;
            id->w = 0.0f;
            /* the I/f frame is off the rotor by its load angle, up to a quarter turn while the rotor lags
             * the ramp: the loops on the smaller inductance on both axes, so that neither sees more gain
             * than it was designed for whichever axis of the rotor it sits on (the Baldor PM-SyRM, L_q 5.5
             * L_d: its q loop on the rotor's d axis rang at the voltage limit and the spin stalled at a
             * fifth of its speed); the frame's own L_d, L_q again once FLUX has locked it onto the EMF */
            ident_design_pi(id, fs_minf(r->L_d, r->L_q), fs_minf(r->L_d, r->L_q), r->R_s);
            return (fs_ab){0.0f, 0.0f};
        }
        r->motion_ldq = e;
        r->eps_align = e;
        /* the carrier on a frame e off the rotor's axis sees 1/L = (1/L_d + 1/L_q)/2 + (1/L_d - 1/L_q)/2 cos 2e:
         * L_d from it with AXIS's L_q */
        const float c2 = fs_cosf(2.0f * e);
        const float lq = r->L_q_axis;
        r->L_d = (lq > 0.0f) ? (1.0f + c2) / ((2.0f / L) - (1.0f - c2) / lq) : L;
    } else {
        r->L_q_bias[level] = L;
        r->I_bias[level] = I_b;
    }
    if (++id->sub < (1 + ldq_n_bias(id))) {
        ldq_clear(id);
        return from_frame(id, u);
    }
    ldq_lq(r, ldq_n_bias(id));
    bool stop = !(r->L_q > 0.0f);
    if (stop) {   /* a curve too bent to extrapolate */
        ident_fail(id, FS_IDQ_LQ, FS_IDR_FIT);
    } else {
        ident_ok(id, FS_IDQ_LD);
        ident_ok(id, FS_IDQ_LQ);
        if (fabsf(r->eps_align) > 0.14f) {   /* 8 deg: L_d off by (L_q/L_d - 1) eps^2, 2 % at a saliency of 2 */
            ident_fail(id, FS_IDQ_LD, FS_IDR_MISALIGNED);
            id->res.status[FS_IDQ_LQ] = FS_IDS_FAILED;
            id->res.reason[FS_IDQ_LQ] = FS_IDR_MISALIGNED;
            stop = true;
        }
    }
    if (stop) {
        return from_frame(id, u);
    }
    ident_design_pi(id, r->L_d, r->L_q, r->R_s);
    if (r->status[FS_IDQ_MAP] == (int)FS_IDS_PENDING) {
        fs_mapid_config mc = {c->Ts, c->delay, c->i_max, r->L_d, r->L_q, r->R_s, fabsf(r->u_e), c->pole_pairs,
                              c->locked ? 0.0f : c->psi_f_hint, c->locked ? 0.0f : c->J_hint,
                              (c->motion_max > 0.0f) ? c->motion_max : MOTION_MAX, id->w_c, 0, id->pol_known};
        if (fs_mapid_init(&id->map, &mc) != FS_OK) {
            r->status[FS_IDQ_MAP] = FS_IDS_FAILED;
            r->reason[FS_IDQ_MAP] = FS_IDR_FIT;
        }
    }
    ident_goto(id, FS_IDENT_CHECK);   /* before MAP (where it is to be identified) and after it */
    return (fs_ab){0.0f, 0.0f};
}

/* ---- MAP: the flux map's sweeps (fs_mapid.h) on the standstill frame ---- */
static fs_ab step_map(fs_ident *id, fs_ab i_ab)
{
    fs_ab ret;
    const float ct = fs_cosf(id->theta_s);
    const float st = fs_sinf(id->theta_s);
    const fs_dq i = fs_park(i_ab, ct, st);
    const fs_dq e = fs_park(ident_inv_error(id, i_ab, id->u_prev[(id->cfg.delay > 0.0f) ? 1 : 0]), ct, st);
    fs_dq u = fs_mapid_step(&id->map, i, e, id->u_max);
    id->k++;
    if (id->map.stage != (int)FS_MAPID_DONE) { ret = fs_inv_park(u, ct, st); }
    else {
        const fs_mapid_result *m = &id->map.res;
        int n_read = 0;   /* the d axis read to +-3/4 i_max (+-i_max where the sweep's peaks reached it, else from beyond) */
        for (int k = 1; k < (FS_MAPID_ND - 1); ++k) {
            if (m->n_d[k] > 0) { ++n_read; }
        }
        if (m->flipped != 0) { id->theta_s = fs_wrap_pi(id->theta_s + FS_PI); }   /* the magnet's north */
        id->pol_known = id->pol_known || m->decided;   /* ALIGN's or the polarity sweep's stands */
        id->res.theta_axis = id->theta_s;
        /* the d sweep read its whole axis: the map has its spine (the q sweeps
         * read what the disc and the motion leave them) */
        if (n_read == (FS_MAPID_ND - 2)) {
            ident_ok(id, FS_IDQ_MAP);
        } else {
            id->res.status[FS_IDQ_MAP] = FS_IDS_FAILED;
            id->res.reason[FS_IDQ_MAP] = (m->d_limit == (int)FS_MAPID_LIM_UNSTABLE) ? (int)FS_IDR_UNSTABLE : (int)FS_IDR_INCOMPLETE;
        }
        ident_goto(id, FS_IDENT_CHECK);
        ret = (fs_ab){0.0f, 0.0f};
    }
    return ret;
}

/* ---- SPIN: I/f, the current ramped in 20 ms at standstill, then the frame ramp ---- */
static fs_ab step_spin(fs_ident *id, fs_ab i)
{
    const fs_ident_config *c = &id->cfg;
    /* polarity unknown: 0.2 s to the current 90 deg off the axis, 0.2 s
     * turning to it, 0.2 s on it (ALIGN's times: slower than a small
     * rotor's swing); else 20 ms to the current on the axis */
    const float n_a_f = 0.2f / c->Ts;
    const float n_in_f = 0.02f / c->Ts;
    const float n_speed_f = 0.05f / c->Ts;   /* 50 ms at speed */
    const int n_a = id->pol_known ? 0 : (int)n_a_f + 1;
    const int n_in = id->pol_known ? ((int)n_in_f + 1) : (3 * n_a);
    const int n_to = id->pol_known ? n_in : n_a;
    const float i_d = id->i_if * fs_minf((float)id->k / (float)n_to, 1.0f);
    if (!id->pol_known && (id->k <= n_in)) {
        const int n_left = (2 * n_a) - id->k;
        id->theta = fs_wrap_pi(id->theta_s + (0.5f * FS_PI * fs_clamp01((float)n_left / (float)n_a)));
    }
    fs_ab u = frame_current(id, i, (fs_dq){i_d, 0.0f});
    id->k++;
    if (id->k > n_in) {
        if (id->sub == 0) {
            const float m = sqrtf((id->u_dq.d * id->u_dq.d) + (id->u_dq.q * id->u_dq.q));
            if ((id->w >= c->w_spin) || (m > (U_SPIN * id->u_max))) {
                id->sub = 1;   /* hold the speed reached */
                id->w_target = id->w;
                id->n_acc = 0;
            } else {
                id->w += c->w_spin / c->t_ramp * c->Ts;
            }
        } else if (++id->n_acc > (int)n_speed_f) {   /* 50 ms at speed */
            id->bw_pll = fs_minf(0.1f * id->w_c, 0.5f * id->w_target);   /* below the current loop, and a few turns to settle */
            id->w0 = id->w;
            ident_goto(id, FS_IDENT_FLUX);
        } else {
            /* at speed, not yet 50 ms */
        }
        id->theta = fs_wrap_pi(id->theta + (id->w * c->Ts));
    }
    return u;
}

/* ---- FLUX: zero current on the EMF-locked frame; 10/bw to lock, 20/bw to read ---- */
static fs_ab step_flux(fs_ident *id, fs_ab i)
{
    fs_ab ret;
    const fs_ident_config *c = &id->cfg;
    fs_ab u = frame_current(id, i, (fs_dq){0.0f, 0.0f});
    const float phi = frame_pll(id, i);
    const float n_lock_f = 10.0f / (id->bw_pll * c->Ts);
    const int n_lock = (int)n_lock_f + 1;
    const float n_meas_f = 20.0f / (id->bw_pll * c->Ts);
    const int n_meas = (int)n_meas_f + 1;
    id->k++;
    if (id->k == n_lock) {
        /* the frame locked on the EMF: the loops on its own L_d, L_q again (SPIN had them isotropic), their
         * integrators kept (at zero current the output is the integrator: they hold the EMF, no bump) */
        const float integ_d = id->pi_d.integ;
        const float integ_q = id->pi_q.integ;
        ident_design_pi(id, id->res.L_d, id->res.L_q, id->res.R_s);
        id->pi_d.integ = integ_d;
        id->pi_q.integ = integ_q;
    }
    if (id->k <= n_lock) { ret = u; }
    else {
        const fs_dq e = frame_emf(id, i);
        /* the EMF's q part in the locked frame, not its magnitude: the
         * voltage carries the dead time's error of random sign at zero current
         * (16 V on a 637 V link), and the mean magnitude of a noisy vector is
         * biased up by sigma^2 / 2|e| (+5 % on zoo machine 39); e_q's mean is
         * not (cos phi of the lock's small jitter aside) */
        const float em = e.q * ((id->w >= 0.0f) ? 1.0f : -1.0f);
        /* the frame's own speed w (not the PLL's integral w0, which lags a
         * decelerating rotor by 2 a / bw_pll: 6 % on a machine whose friction
         * halves its speed in the window): its mean is the frame's turn over
         * the window, which is the rotor's */
        const float ratio = em / fs_maxf(fabsf(id->w), 1e-6f);
        if (id->n_acc == 0) { id->u0 = ratio; }
        id->e_abs += em;
        id->w_abs += fabsf(id->w);
        id->s_u += ratio - id->u0;
        id->s_uu += (ratio - id->u0) * (ratio - id->u0);
        id->s_i += phi;   /* signed: its mean is the lock's offset, the noise averages out */
        id->n_acc++;
        if ((uint32_t)id->n_acc < ((uint32_t)n_meas << (2u * (uint32_t)id->sub))) { ret = u; }   /* counts >= 0: shifted unsigned, the same */
        else {
            fs_ident_result *r = &id->res;
            const int n = id->n_acc;
            r->w_flux = id->w_abs / (float)n;
            if (r->w_flux < (0.1f * id->w_target)) {
                ident_fail(id, FS_IDQ_PSI_F, FS_IDR_NOT_TURNING);
                ret = u;
            }
            else if ((r->w_flux > (1.5f * id->w_target)) || (r->w_flux < (0.5f * id->w_target)) || fabsf(id->s_i) / (float)n > 0.1f) {
                ident_fail(id, FS_IDQ_PSI_F, FS_IDR_LOST_SYNC);
                ret = u;
            }
            else {
                r->psi_f = id->e_abs / id->w_abs;
                r->snr_psi = r->psi_f / fs_maxf(acc_std(id->s_u, id->s_uu, n) / sqrtf((float)n), 1e-30f);
                if ((r->snr_psi < 50.0f) && (r->snr_psi > 10.0f) && (id->sub < 2)) {
                    id->sub++;   /* a noisy EMF: the window four times longer, twice at most */
                    ret = u;
                }
                /* below: the EMF lost in the inverter's error of random sign at zero
                 * current (the Prius-like bench at 0.3 of rated speed: 27 V against
                 * 15 V a leg; [identify] speed_frac raises it) */
                else if (r->snr_psi < 50.0f) {
                    ident_fail(id, FS_IDQ_PSI_F, FS_IDR_LOW_SIGNAL);
                    ret = u;
                }
                else {
                    ident_ok(id, FS_IDQ_PSI_F);
                    id->i_acc = I_ACC * c->i_max;
                    id->w_target = id->w0;
                    rec_clear(id);
                    ident_goto(id, (id->res.status[FS_IDQ_MAP] == (int)FS_IDS_OK) ? FS_IDENT_DCURVE : FS_IDENT_ACCEL);
                    ret = u;
                }
            }
        }
    }
    return ret;
}

static int abs_level(int k) { return (k < 0) ? -k : k; }

/* ---- DCURVE: the map's d levels at speed, i_q = 0, each settled then averaged ----
 * psi_d(i_d, 0) = (u_q - R_s i_q) / w less the inverter's error, from the
 * steady voltage equations: no integral, no torque (i_q = 0 and
 * psi_q(i_d, 0) = 0: the PLL's e_d stays the d axis' error). Levels whose
 * voltage w (psi_f + L_d i_d) would pass U_DCURVE of the limit are left
 * to the standstill sweep. */
static fs_ab step_dcurve(fs_ident *id, fs_ab i_ab)
{
    fs_ab ret;
    const fs_ident_config *c = &id->cfg;
    fs_ident_result *r = &id->res;
    const float n_set_f = 30.0f / (id->w_c * c->Ts);
    const int n_set = (int)n_set_f + 1;
    /* the rotor coasts at i_q = 0: below half the speed FLUX ended at, where the PLL's bandwidth (half the
     * spin's speed) nears the speed itself, no more levels (the standstill sweep has them). A light rotor
     * with viscous friction (anaheim-bly171d, J/B = 0.21 s) halved its speed in FLUX and turned backwards
     * in DCURVE, the frame lost: ACCEL then pushed its torque on a frame off the rotor for 20 s */
    if ((id->k == 0) && (id->sub < FS_MAPID_ND) && (fabsf(id->w0) < (0.5f * fabsf(id->w_target)))) { id->sub = FS_MAPID_ND; }
    /* nor on once a level moved the speed by a fifth (at i_q = 0 only a frame off the axis makes torque,
     * and its torque turns the frame further off: the light rotor above reversed within a level); its
     * current ramps back to zero from where it is */
    if (id->k == 0) { id->w_level = id->w0; }
    else if ((id->sub < FS_MAPID_ND) && (fabsf(id->w0 - id->w_level) > (0.2f * fabsf(id->w_level)))) {
        const int lvl = id->sub - (FS_MAPID_ND / 2);
        const float i_lvl = 0.25f * (float)lvl * c->i_max;   /* the level's d current */
        id->i_ref0 = (id->k <= n_set) ? (id->i_ref0 + ((i_lvl - id->i_ref0) * fs_minf((3.0f * (float)id->k) / (float)n_set, 1.0f)))
                                      : i_lvl;
        acc_clear(id);
        id->k = 0;
        id->sub = FS_MAPID_ND;
    } else {
        /* the level holds the speed */
    }
    while (id->sub < FS_MAPID_ND) {   /* the next level the voltage and the frame's lock allow (0 is psi_f, read by FLUX) */
        const int kk = id->sub - (FS_MAPID_ND / 2);
        const float I = 0.25f * (float)kk * c->i_max;
        /* a level whose d current turns a misaligned rotor further off (1.5 p (psi_f I - (L_q - L_d) I^2) < 0:
         * every I < 0, and I > psi_f / (L_q - L_d)) is a loop of the frame's lock error through the torque:
         * its open rate sqrt(p |K| / J) must stay within half the PLL's bandwidth, or the frame loses the
         * rotor (anaheim-bly171d: 322 rad/s at -i_max / 2 on J = 2.4e-6 kg m^2 against a 250 rad/s PLL; the
         * rotor reversed in the level). At a third, siemens-1ft6084's -i_max/2 (54 rad/s against 157) was
         * left to the standstill sweep, whose dead time reads a 10 % asymmetry into its linear d axis.
         * The nameplate's J (unknown: no bound) */
        const float K = 1.5f * (float)c->pole_pairs * ((r->psi_f * I) - ((r->L_q - r->L_d) * I * I));
        const bool holds = !(K < 0.0f) || !(c->J_hint > 0.0f)
                           || (((float)c->pole_pairs * -K / c->J_hint) < ((id->bw_pll * id->bw_pll) / 4.0f));
        if ((kk != 0) && (abs_level(kk) <= DCURVE_LEVELS) && holds
            && ((fabsf(id->w) * (r->psi_f + (r->L_d * I))) < (U_DCURVE * id->u_max))) {
            break;
        }
        id->sub++;
    }
    const int k_level = id->sub - (FS_MAPID_ND / 2);
    const float I = (id->sub < FS_MAPID_ND) ? (0.25f * (float)k_level * c->i_max) : 0.0f;
    /* each level reached by a ramp from the last over a third of the settling (a step of i_max overshoots at speed) */
    const float ramp = fs_minf(3.0f * (float)id->k / (float)n_set, 1.0f);
    fs_ab u = frame_current(id, i_ab, (fs_dq){id->i_ref0 + (I - id->i_ref0) * ramp, 0.0f});
    (void)frame_pll(id, i_ab);
    if (id->sub >= FS_MAPID_ND) {   /* all read: back to zero current, then ACCEL from this speed */
        if (++id->k > n_set) {
            id->w_target = id->w0;
            rec_clear(id);
            ident_goto(id, FS_IDENT_ACCEL);
        }
        ret = u;
    }
    else if (++id->k <= n_set) { ret = u; }
    else {
        const fs_dq e = frame_emf(id, i_ab);
        const float ct = fs_cosf(id->theta);
        const float st = fs_sinf(id->theta);
        const fs_dq i = fs_park(i_ab, ct, st);
        id->s_u += (e.q / id->w) + (r->L_d * i.d);   /* psi_d = e_q / w + L_d i_d (frame_emf took w L_d i_d out) */
        id->s_i += i.d;
        id->s_ia += id->w;
        id->s_ii += fabsf(fs_atan2f(-e.d, e.q));   /* the frame's lock on the d axis: the PLL's phase error */
        if (id->n_acc == 0) { id->u0 = id->w; }
        if (++id->n_acc < n_set) { ret = u; }
        else {
            const float n = (float)id->n_acc;
            /* a level is read where the frame held the d axis (the PLL's error within DCURVE_LOCK) and the
             * speed within 10 %: a frame off the axis turns the d current into torque, and the torque turns
             * the frame further off (zoo machine 0 stopped under -i_max from 4 el.deg) */
            if (((id->s_ii / n) < DCURVE_LOCK) && (fabsf(id->w - id->u0) < (0.1f * fabsf(id->u0)))) {
                r->psi_d_w[id->sub] = id->s_u / n;
                r->i_d_w[id->sub] = id->s_i / n;
                r->w_d_w[id->sub] = id->s_ia / n;
            }
            acc_clear(id);
            id->k = 0;
            id->sub++;
            id->i_ref0 = I;
            ret = u;
        }
    }
    return ret;
}

/* The torque of the measured current i_f in the frame, N m: turned into
 * the rotor's frame by the frame's lag behind the back-EMF's axis (its angle
 * in the frame), with the identified psi_f, L_d, L_q. The current loop's
 * error against the reference, the back-EMF's ramp its integral follows
 * while the speed rises, is in it: with the reference's torque in place of
 * it the zoo's J came out 0.4..5 % high (100 of 100 above the truth; zoo
 * machine 0's q current 2.9 % below its reference), and the PLL's lag under
 * the acceleration, a/bw_pll^2 (3 el.deg on zoo machine 1), puts part of it
 * on d. */
static float accel_torque(const fs_ident *id, fs_dq i_f, fs_dq e)
{
    const fs_ident_result *r = &id->res;
    const float s = (id->w >= 0.0f) ? 1.0f : -1.0f;
    const float eps = fs_atan2f(-s * e.d, s * e.q);   /* the rotor's q axis (the EMF's) ahead of the frame's */
    const float ce = fs_cosf(eps);
    const float se = fs_sinf(eps);
    const float i_d = (ce * i_f.d) + (se * i_f.q);
    const float i_q = (ce * i_f.q) - (se * i_f.d);
    return 1.5f * (float)id->cfg.pole_pairs * ((r->psi_f * i_q) + ((r->L_d - r->L_q) * i_d * i_q));
}

/* ---- ACCEL: i_q = i_acc until the speed is 1.4x, the voltage at U_ACC, or 20 ramp times ---- */
static fs_ab step_accel(fs_ident *id, fs_ab i)
{
    const fs_ident_config *c = &id->cfg;
    const fs_dq i_f = fs_park(i, fs_cosf(id->theta), fs_sinf(id->theta));
    fs_ab u = frame_current(id, i, (fs_dq){0.0f, id->i_acc});
    const fs_dq e = frame_emf(id, i);   /* as frame_pll reads it, before it turns the frame */
    (void)frame_pll(id, i);
    const float t = (float)id->k * c->Ts;
    id->g_acc += c->Ts * accel_torque(id, i_f, e);
    rec_push(id, t, id->w0, id->g_acc);
    id->k++;
    const float m = sqrtf((id->u_dq.d * id->u_dq.d) + (id->u_dq.q * id->u_dq.q));
    if ((id->w0 >= (1.4f * id->w_target)) || (m > (U_ACC * id->u_max)) || (t > (20.0f * c->t_ramp))) {
        id->t_acc = t;
        /* the fit skips the PLL's transient, 4/bw: what is left must hold 10/bw */
        const float t_skip = 4.0f / id->bw_pll;
        const float t_need = t_skip + (10.0f / id->bw_pll);
        float a;
        float tm;
        float wm;
        int k0 = 0;
        while ((k0 < id->rec_n) && (id->rec_t[k0] < t_skip)) { ++k0; }
        float T_fit;
        float gm;
        if ((t < t_need) || !rec_fit(id, id->rec_w, k0, id->rec_n, &a, &tm, &wm)
            || !rec_fit(id, id->rec_g, k0, id->rec_n, &T_fit, &tm, &gm)) {
            /* again after the coast, at a quarter of the current, or less where this try showed the rotor
             * light for it: the current that makes the next rise (0.4 of the speed it starts from, which a
             * frictionless rotor keeps from this one) take twice t_need at the acceleration seen here.
             * A quarter a try left the frictionless Prius MG2 (0.035 kg m^2, 271 A) at 5 A, its rise 0.19 s
             * against 0.25 s needed, and J failed "too fast". The next current above three times the
             * sensors' noise (START), and 0.2 % of i_max (a few ADC steps), for the loop to hold it */
            const float dw = id->w0 - ((id->rec_n > 0) ? id->rec_w[0] : id->w0);
            float a_seen = 0.0f;   /* el. rad/s^2 */
            if (t > 0.0f) { a_seen = dw / t; }
            float i_next = 0.25f * id->i_acc;
            if (a_seen > 0.0f) { i_next = fs_minf(i_next, (id->i_acc * ((0.4f * fabsf(id->w0)) / (2.0f * t_need))) / a_seen); }
            if ((i_next > fs_maxf(3.0f * id->res.noise_i, 0.002f * c->i_max)) && (id->tries < 3)) {
                id->tries++;
                id->sub = 1;
                id->i_acc = i_next;
            } else {
                ident_fail(id, FS_IDQ_J, FS_IDR_TOO_FAST);
                return u;
            }
        } else {
            id->res.a_acc = a;
            id->T_acc = T_fit;   /* the torque as the same fit weighs it, sample by sample */
            id->w_acc = wm;   /* the acceleration's mean speed, for the coast's interpolation */
            id->sub = 0;
        }
        const int redo = id->sub;
        rec_clear(id);
        ident_goto(id, FS_IDENT_COAST);
        id->sub = redo;
    }
    return u;
}

/* ---- COAST: zero current until back at the start speed, or 4 t_acc (at least 20/bw) ---- */
static fs_ab step_coast(fs_ident *id, fs_ab i)
{
    fs_ab ret;
    const fs_ident_config *c = &id->cfg;
    fs_ab u = frame_current(id, i, (fs_dq){0.0f, 0.0f});
    (void)frame_pll(id, i);
    const float t = (float)id->k * c->Ts;
    rec_push(id, t, id->w0, 0.0f);
    id->k++;
    const float t_max = fs_maxf(4.0f * id->t_acc, 20.0f / id->bw_pll);
    if ((id->w0 > id->w_target) && (t < t_max)) { ret = u; }
    else {
        fs_ident_result *r = &id->res;
        if (id->w0 < (0.2f * id->w_target)) {
            ident_fail(id, FS_IDQ_J, FS_IDR_LOST_SYNC);
            ret = u;
        }
        else if (id->sub == 1) {   /* a retry of the acceleration at the current set above */
            id->w_target = id->w0;
            rec_clear(id);
            ident_goto(id, FS_IDENT_ACCEL);
            ret = u;
        }
        else {
            /* the deceleration in two halves, after the PLL's transient */
            int k0 = 0;
            while ((k0 < id->rec_n) && (id->rec_t[k0] < (4.0f / id->bw_pll))) { ++k0; }
            const int kh = (k0 + id->rec_n) / 2;
            float a1;
            float a2;
            float t1;
            float t2;
            float w1;
            float w2;
            if (!rec_fit(id, id->rec_w, k0, kh, &a1, &t1, &w1) || !rec_fit(id, id->rec_w, kh, id->rec_n, &a2, &t2, &w2)) {
                ident_fail(id, FS_IDQ_J, FS_IDR_TOO_FAST);
                ret = u;
            }
            else {
                const float w_acc = id->w_acc;
                float slope = 0.0f;
                float a_c = 0.5f * (a1 + a2);
                if (fabsf(w1 - w2) > (0.02f * fabsf(w1))) {   /* two distinct speeds: a line a(w) */
                    slope = (a1 - a2) / (w1 - w2);
                    a_c = a1 + (slope * (w_acc - w1));
                }
                r->a_coast = a_c;
                const float p = (float)c->pole_pairs;
                const float T = id->T_acc;
                const float da = r->a_acc - a_c;
                if (!(da > 0.0f)) {
                    ident_fail(id, FS_IDQ_J, FS_IDR_FIT);
                    ret = u;
                }
                /* the test torque must not be below friction: J comes from a
                 * difference of accelerations, the coast's taken at other currents and
                 * speeds (zou2021 with a retry at a third of friction: J 24 % off;
                 * a quarter refused four zoo machines whose J was within 9 %) */
                else if (fabsf(a_c) > da) {
                    ident_fail(id, FS_IDQ_J, FS_IDR_FRICTION);
                    ret = u;
                }
                else {
                    r->J = T * p / da;   /* a_e = p a_m */
                    ident_ok(id, FS_IDQ_J);
                    /* a_e = -(B/J) w_e - p T_c / J */
                    r->B = fs_maxf(-slope * r->J, 0.0f);
                    r->T_c = -(a1 - (slope * w1)) * r->J / p;
                    if (!(slope < 0.0f)) {   /* one speed, or friction falling with speed: all of it as Coulomb at the mean speed */
                        r->B = 0.0f;
                        r->T_c = -a_c * r->J / p;
                    }
                    ident_ok(id, FS_IDQ_FRICTION);
                    ident_goto(id, FS_IDENT_DONE);
                    ret = u;
                }
            }
        }
    }
    return ret;
}

fs_ab fs_ident_step(fs_ident *id, fs_ab i_ab, float u_dc)
{
    const fs_ident_config *c = &id->cfg;
    id->u_max = fs_maxf(u_dc, 0.0f) * FS_INV_SQRT3;
    const float i_mag = sqrtf((i_ab.alpha * i_ab.alpha) + (i_ab.beta * i_ab.beta));
    fs_ab u = {0.0f, 0.0f};
    if ((id->step >= 0) && (id->step < (int)FS_IDENT_NSTEPS)) { id->res.n_step[id->step]++; }
    id->res.n_total++;
    const float trip = ((id->step == (int)FS_IDENT_MAP) || (id->step == (int)FS_IDENT_POLARITY)) ? 1.15f : 1.1f;
    if ((id->step != (int)FS_IDENT_FAILED) && (id->step != (int)FS_IDENT_DONE) && (i_mag > (trip * c->i_max))) {
        /* 10 % over i_max: the HF and the loops' overshoot stay below; 15 % in MAP: its q sweeps stop at
         * 1.06 (fs_mapid.h), the period of delay and one step on */
        static const int q_of_step[FS_IDENT_NSTEPS] = {
            FS_IDQ_VERR, FS_IDQ_VERR, FS_IDQ_LD, FS_IDQ_VERR, FS_IDQ_VERR, FS_IDQ_VERR, FS_IDQ_LD, FS_IDQ_MAP,
            FS_IDQ_MAP, FS_IDQ_PSI_F, FS_IDQ_PSI_F, FS_IDQ_MAP, FS_IDQ_J, FS_IDQ_J, FS_IDQ_J, FS_IDQ_J};
        ident_fail(id, q_of_step[id->step], FS_IDR_OVERCURRENT);
    }
    switch (id->step) {
    case FS_IDENT_START:
        /* N_NOISE periods at zero voltage: the current sensors' noise (ALIGN tells a rotor at rest by it) */
        if (u_dc > fs_maxf(c->u_dc_min, 1.0f)) {
            id->s_ii += 0.5f * ((i_ab.alpha * i_ab.alpha) + (i_ab.beta * i_ab.beta));
            if (++id->k >= N_NOISE) {
                id->res.noise_i = sqrtf(id->s_ii / (float)id->k);
                ident_goto(id, FS_IDENT_PROBE);
            }
        }
        break;
    case FS_IDENT_PROBE: u = step_probe(id, i_ab); break;
    case FS_IDENT_AXIS: u = step_axis(id, i_ab); break;
    case FS_IDENT_ALIGN: u = step_align(id, i_ab); break;
    case FS_IDENT_POLARITY: u = step_polarity(id, i_ab); break;
    case FS_IDENT_LEVELS: u = step_levels(id, i_ab); break;
    case FS_IDENT_LDQ: case FS_IDENT_CHECK: u = step_ldq(id, i_ab); break;
    case FS_IDENT_MAP: u = step_map(id, i_ab); break;
    case FS_IDENT_SPIN: u = step_spin(id, i_ab); break;
    case FS_IDENT_FLUX: u = step_flux(id, i_ab); break;
    case FS_IDENT_DCURVE: u = step_dcurve(id, i_ab); break;
    case FS_IDENT_ACCEL: u = step_accel(id, i_ab); break;
    case FS_IDENT_COAST: u = step_coast(id, i_ab); break;
    case FS_IDENT_DONE:
        /* zero current on the tracking frame while the rotor coasts: zero
         * voltage would short the EMF */
        u = frame_current(id, i_ab, (fs_dq){0.0f, 0.0f});
        if ((id->bw_pll > 0.0f) && fabsf(id->w0) > (0.05f * id->w_target)) { (void)frame_pll(id, i_ab); }
        break;
    default:   /* FAILED: zero current where a frame is known (tracking the EMF once it was), else zero voltage */
        if (id->res.status[FS_IDQ_LQ] == (int)FS_IDS_OK) {
            u = frame_current(id, i_ab, (fs_dq){0.0f, 0.0f});
            if ((id->bw_pll > 0.0f) && fabsf(id->w0) > (0.05f * id->w_target)) { (void)frame_pll(id, i_ab); }
        }
        break;
    }
    id->u_prev[1] = id->u_prev[0];
    id->u_prev[0] = u;
    return u;
}
