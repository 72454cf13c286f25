/* fs-test-sources: control/fs_monitor.c control/fs_transforms.c control/fs_status.c
 *
 * fs_monitor: the lock checks that do not trust the estimator. A machine
 * (non-salient, so that the model is exact for any angle) turning at 2000
 * rpm with 20 A on the loops' q axis gives the voltage and current of its
 * model; the loops' angle and speed are the rotor's (on track), 30 or 100
 * el.deg off, pi off, spinning the other way, or three times too fast: only
 * the first two keep the back-EMF residual below 1. The slip: an estimate
 * stuck at standstill, or turning at 0.9 and 0.5 of the rotor's speed, is
 * measured at the slip it has (flagged past pi / t_lost, not below); a
 * carrier's leak turning at its frequency stays out of it. The jump: the
 * loops' angle stepping 120 el.deg latches, 30 el.deg does not; a speed
 * state off by 100 el. rad/s while the angle tracks does not, 250 does. At
 * standstill the mechanics judge: an estimate whose motion implies a load of
 * 2 T_max is off, a load of half T_max is not. The torque's sign: a torque
 * rising to half T_max that the loops' speed answers the other way (0.15 of
 * it, an implied load the mechanics' bound does not reach) with the EMF
 * pointing back is flagged; answered the right way, or with the EMF
 * forward, or too slow a change, it is not. The current loops' error (held
 * while the voltage is short at a speed that may explain it, counted where
 * it cannot), switching off, the warm-up and its count held, and the
 * refusals.
 */
#include <math.h>

#include "control/fs_monitor.h"
#include "fs_test.h"

/* yang2022's machine, bench and limits */
static const fs_monitor_config CFG = {1e-4f, 0, 0.036f, 65e-6f, 65e-6f, 0.007f, 5, 1.87e-3f, 0.0f,
                                      3.2f, 60.0f, 0.01f, 5e-3f, 20e-3f, 0.0f};
#define U_DC 24.0f

/* The current j i_q e^{j phi} on the loops' q axis (phi = k_th w t + off). */
static fs_ab current(double t, double w, double k_th, double off, double i_q)
{
    const double phi = k_th * w * t + off;
    return (fs_ab){(float)(-i_q * sin(phi)), (float)(i_q * cos(phi))};
}

/* The model's voltage over (t0, t0 + Ts), alpha-beta: R i + L di/dt (the
 * period's mean) + the EMF at the period's middle, the rotor at w t. */
static fs_ab model_u(double t0, double w, double k_th, double off, double i_q)
{
    const double Ts = CFG.Ts, th = w * (t0 + 0.5 * Ts), E = w * CFG.psi_f;
    const fs_ab i0 = current(t0, w, k_th, off, i_q), i1 = current(t0 + Ts, w, k_th, off, i_q);
    fs_ab u;
    u.alpha = (float)(CFG.R_s * 0.5 * (i0.alpha + i1.alpha) + CFG.L_d * (i1.alpha - i0.alpha) / Ts - E * sin(th));
    u.beta = (float)(CFG.R_s * 0.5 * (i0.beta + i1.beta) + CFG.L_d * (i1.beta - i0.beta) / Ts + E * cos(th));
    return u;
}

/* Runs 0.1 s with the loops' angle theta_hat(t) = k_th w t + off and speed
 * k_th w, a voltage u_leak e^{j w_h t} added in the loops' frame (a
 * carrier's leak turning at the carrier's frequency, cfg.w_h = w_h);
 * returns the largest residual over the last half, and the largest r_slip
 * in *slip_max. */
static float run_emf_leak(double w, double k_th, double off, double u_leak, double w_h, fs_monitor *m, float *slip_max)
{
    fs_monitor_config cfg = CFG;
    cfg.w_h = (float)w_h;
    FS_CHECK(fs_monitor_init(m, &cfg) == FS_OK, "init");
    const double Ts = CFG.Ts, i_q = 20.0;
    float r_max = 0.0f;
    *slip_max = 0.0f;
    for (int k = 0; k < 1000; ++k) {
        const double t = k * Ts;
        const double th = k_th * w * t + off;
        fs_ab u = model_u(t, w, k_th, off, i_q);
        const double ph = th + 0.5 * k_th * w * Ts + w_h * (t + 0.5 * Ts);
        u.alpha += (float)(u_leak * cos(ph));
        u.beta += (float)(u_leak * sin(ph));
        fs_monitor_in in = {current(t, w, k_th, off, i_q), u, U_DC,
                            (float)fs_test_wrap(th), (float)(k_th * w), (float)cos(th), (float)sin(th),
                            {0.0f, (float)i_q}, 2.0f, {0.0f, 0.0f}, true, false};
        float r = fs_monitor_step(m, &in);
        if (k >= 500 && r > r_max) r_max = r;
        if (k >= 500 && m->r_slip > *slip_max) *slip_max = m->r_slip;
    }
    return r_max;
}

static float run_emf(double w, double k_th, double off, fs_monitor *m)
{
    float slip;
    return run_emf_leak(w, k_th, off, 0.0, 0.0, m, &slip);
}

/* The loops on track at w (their angle w t), from 50 ms on their angle
 * stepped by `step` and their speed state off by dw while the angle keeps
 * tracking; returns whether the monitor latched `jumped` in 0.1 s, and the
 * largest |jump| in *peak. */
static bool run_jump(double w, double step, double dw, fs_monitor *m, float *peak)
{
    FS_CHECK(fs_monitor_init(m, &CFG) == FS_OK, "init");
    *peak = 0.0f;
    const double Ts = CFG.Ts, i_q = 20.0;
    for (int k = 0; k < 1000; ++k) {
        const double t = k * Ts, th = w * t + (k >= 500 ? step : 0.0);
        fs_monitor_in in = {current(t, w, 1.0, 0.0, i_q), model_u(t, w, 1.0, 0.0, i_q), U_DC,
                            (float)fs_test_wrap(th), (float)(w + (k >= 500 ? dw : 0.0)), (float)cos(th), (float)sin(th),
                            {0.0f, (float)i_q}, 2.0f, {0.0f, 0.0f}, true, false};
        fs_monitor_step(m, &in);
        if (fabsf(m->jump) > *peak) *peak = fabsf(m->jump);
    }
    return m->jumped;
}

/* Standstill-ish: the loops' speed accelerates at a (el. rad/s^2) from 0
 * while T_ref is commanded; returns the mechanical residual at the end.
 * A 100 V link: its 2 % in the error bound keeps the EMF unjudged up to the
 * 430 el. rad/s reached. */
static float run_mech(float T_ref, double a, fs_monitor *m)
{
    FS_CHECK(fs_monitor_init(m, &CFG) == FS_OK, "init");
    for (int k = 0; k < 500; ++k) {   /* 50 ms: 10 tau */
        const double t = k * CFG.Ts;
        const double th = 0.5 * a * t * t;
        fs_monitor_in in = {{0.0f, 5.0f}, {0.0f, 0.0f}, 100.0f, (float)fs_test_wrap(th), (float)(a * t),
                            (float)cos(th), (float)sin(th), {(float)(5.0 * sin(th)), (float)(5.0 * cos(th))},
                            T_ref, {0.0f, 0.0f}, true, false};
        fs_monitor_step(m, &in);
    }
    return m->r_mech;
}

/* Near standstill, no current: T_ref ramps from 0 to T_peak over 60 ms and
 * holds; the loops' speed answers it with the acceleration k_T T_ref p / J
 * (k_T = 1: the torque moves the rotor; -0.15: a reversed torque, weakened
 * by the angle error) from 20 el. rad/s the way it pushes (no reversal of
 * the speed within the run); the voltage is the EMF of that
 * speed, in the loops' frame along their direction of rotation times
 * emf_dir (-1: pointing back). A 100 V link keeps the EMF unjudged (E_hat
 * below 3 E_err). Returns the largest r_sign over 0.1 s and the largest of
 * the other residuals in *r_other. */
static float run_sign(double k_T, double emf_dir, double T_peak, fs_monitor *m, float *r_other)
{
    FS_CHECK(fs_monitor_init(m, &CFG) == FS_OK, "init");
    const double Ts = CFG.Ts, k_a = CFG.pole_pairs / CFG.J;
    double w = k_T < 0.0 ? -20.0 : 20.0, th = 0.0;
    float r_max = 0.0f;
    *r_other = 0.0f;
    for (int k = 0; k < 1000; ++k) {
        const double t = k * Ts;
        const double T_ref = T_peak * fmin(t / 0.06, 1.0);
        const double s = w < 0.0 ? -1.0 : 1.0, E = emf_dir * s * fabs(w) * CFG.psi_f;
        const double th_n = th + w * Ts;   /* the EMF acting over the next period, along q */
        fs_monitor_in in = {{0.0f, 0.0f}, {(float)(-E * sin(th_n)), (float)(E * cos(th_n))}, 100.0f,
                            (float)fs_test_wrap(th), (float)w, (float)cos(th), (float)sin(th), {0.0f, 0.0f},
                            (float)T_ref, {0.0f, 0.0f}, true, false};
        fs_monitor_step(m, &in);
        r_max = fmaxf(r_max, m->r_sign);
        *r_other = fmaxf(*r_other, fmaxf(fmaxf(m->r_dir, m->r_slip), fmaxf(m->r_mech, m->r_cur)));
        th += w * Ts;
        w += k_T * T_ref * k_a * Ts;
    }
    return r_max;
}

int main(void)
{
    fs_monitor m;
    const double w = 2000.0 / 60.0 * 2.0 * FS_TEST_PI * 5.0;   /* 2000 rpm, el. rad/s */

    float r = run_emf(w, 1.0, 0.0, &m);
    FS_CHECK(r < 0.5f, "on track: residual %g", r);
    FS_CHECK(m.E_hat > 3.0f * m.E_err, "the EMF judged at 2000 rpm: E_hat %g, E_err %g", m.E_hat, m.E_err);
    FS_CHECK_REL(m.e_q, w * CFG.psi_f, 0.03, 0.0, "on track the EMF is w psi_f on q");
    FS_CHECK(fabsf(m.e_d) < 0.05f * m.e_q, "and nothing on d: %g", m.e_d);
    FS_CHECK(run_emf(w, 1.0, 0.5, &m) < 1.0f, "30 el.deg off: not lost");
    r = run_emf(w, 1.0, FS_TEST_PI, &m);
    FS_CHECK(r > 1.5f && m.r_dir == r, "pi off: residual %g from the EMF's direction", r);
    FS_CHECK(run_emf(w, 1.0, 1.75, &m) > 1.0f, "100 el.deg off: lost");
    r = run_emf(w, -1.0, 0.0, &m);
    FS_CHECK(r > 1.0f, "an estimate turning the other way: residual %g", r);
    r = run_emf(w, 3.0, 0.0, &m);
    FS_CHECK(r > 1.0f, "an estimate three times too fast: residual %g", r);

    /* the slip: the EMF's turn in the loops' frame against pi / t_lost */
    const double slip_bound = FS_TEST_PI / CFG.t_lost;
    float slip;
    run_emf_leak(w, 1.0, 0.0, 0.0, 0.0, &m, &slip);
    FS_CHECK(slip < 0.05f, "on track the EMF stands still in the loops' frame: r_slip %g", slip);
    r = run_emf_leak(w, 0.0, 0.3, 0.0, 0.0, &m, &slip);
    FS_CHECK(slip > 5.0f && r >= slip, "an estimate stuck at standstill, the rotor at 2000 rpm: r_slip %g", slip);
    FS_CHECK_REL(slip, w / slip_bound, 0.05, 0.0, "measured at the slip it has (w)");
    run_emf_leak(w, 0.5, 0.0, 0.0, 0.0, &m, &slip);
    FS_CHECK_REL(slip, 0.5 * w / slip_bound, 0.05, 0.0, "at half the rotor's speed: r_slip at the slip 0.5 w");
    run_emf_leak(w, 1.0 - 0.8 * slip_bound / w, 0.0, 0.0, 0.0, &m, &slip);
    FS_CHECK(slip > 0.7f && slip < 0.9f, "a slip of 0.8 pi / t_lost is not flagged: r_slip %g", slip);
    /* a carrier's leak of 1.5 times the EMF turning at 1 kHz in the loops'
     * frame: the pre-filter keeps it out of the turn measured (without it
     * the leak's turn would weigh 2.25 times the EMF's: r_slip about 28) */
    r = run_emf_leak(w, 1.0, 0.0, 1.5 * w * CFG.psi_f, 2.0 * FS_TEST_PI * 1000.0, &m, &slip);
    FS_CHECK(slip < 0.5f && r < 1.0f, "a turning leak: r_slip %g, residual %g", slip, r);

    /* the jump: the loops' angle turning beyond their speed */
    float peak;
    FS_CHECK(run_jump(w, 2.0 * FS_TEST_PI / 3.0, 0.0, &m, &peak), "an angle step of 120 el.deg latches: peak %g", peak);
    FS_CHECK(!run_jump(w, FS_TEST_PI / 6.0, 0.0, &m, &peak), "30 el.deg does not: peak %g", peak);
    FS_CHECK_NEAR(peak, FS_TEST_PI / 6.0, 0.01, "the step itself");
    FS_CHECK_NEAR(m.jump, FS_TEST_PI / 6.0 * exp(-2.0 * 0.05 / CFG.t_lost), 0.002, "leaked over t_lost / 2 since");
    FS_CHECK(!run_jump(w, 0.0, -100.0, &m, &peak), "a speed state 100 el. rad/s off while the angle tracks: peak %g", peak);
    FS_CHECK_NEAR(peak, 100.0 * 0.5 * CFG.t_lost, 0.05, "its turn settles at dw t_lost / 2");
    FS_CHECK(run_jump(w, 0.0, -250.0, &m, &peak), "250 el. rad/s off (beyond pi / t_lost): peak %g", peak);

    /* mechanics: the drive pushes T_max, the loops' speed runs the other way
     * as fast as T_max can turn it: an implied load of 2 T_max */
    const double a_T = CFG.T_max * CFG.pole_pairs / CFG.J;   /* el. rad/s^2 per T_max */
    r = run_mech(CFG.T_max, -a_T, &m);
    FS_CHECK(r > 1.2f && !m.jumped, "reversed torque: r_mech %g, T_L_hat %g", r, m.T_L_hat);
    FS_CHECK_REL(m.T_L_hat, 2.0f * CFG.T_max, 0.05, 0.0, "the implied load");
    r = run_mech(CFG.T_max, 0.5 * a_T, &m);
    FS_CHECK(r < 0.5f, "half of T_max accelerates, half is load: r_mech %g", r);
    FS_CHECK(m.r_dir < 1.0f && m.E_hat < 3.0f * m.E_err, "no EMF judged near standstill");

    /* the torque's sign: the acceleration's answer per unit torque is k_T */
    float other;
    r = run_sign(-0.15, -1.0, 0.5 * CFG.T_max, &m, &other);
    FS_CHECK(r > 1.1f && other < 1.0f, "a reversed torque, EMF pointing back: r_sign %g, the others %g", r, other);
    FS_CHECK_NEAR(r, 1.15f, 0.03f, "1 - k_T: the answer is -0.15 of the torque");
    r = run_sign(1.0, -1.0, 0.5 * CFG.T_max, &m, &other);
    FS_CHECK(r < 0.3f, "the torque moving the rotor, EMF pointing back: r_sign %g", r);
    r = run_sign(-0.15, 1.0, 0.5 * CFG.T_max, &m, &other);
    FS_CHECK(r == 0.0f, "a reversed answer but the EMF forward: not judged, r_sign %g", r);
    r = run_sign(-0.15, -1.0, 0.05 * CFG.T_max, &m, &other);
    FS_CHECK(r == 0.0f, "a torque change under k_exc T_max in t_lost: not judged, r_sign %g", r);

    /* the current loops' error */
    FS_CHECK(fs_monitor_init(&m, &CFG) == FS_OK, "init");
    fs_monitor_in in = {{0.0f, 0.0f}, {0.0f, 0.0f}, U_DC, 0.0f, 0.0f, 1.0f, 0.0f, {0.0f, 0.0f}, 0.0f, {0.0f, 0.3f * CFG.i_max}, true, false};
    for (int k = 0; k < 300; ++k) r = fs_monitor_step(&m, &in);
    FS_CHECK(r > 0.7f && r < 0.76f, "0.3 i_max of error: r_cur %g", r);
    /* the loops' speed raised first, the error as it was */
    const double w_half = 0.5 * U_DC / sqrt(3.0) / (CFG.psi_f + CFG.L_q * CFG.i_max);
    in.w = (float)(1.2 * w_half);
    for (int k = 0; k < 300; ++k) fs_monitor_step(&m, &in);
    FS_CHECK(m.r_cur > 0.7f && m.r_cur < 0.76f, "0.3 i_max of error at speed: r_cur %g", m.r_cur);
    in.i_err.q = 0.5f * CFG.i_max;
    /* with the voltage short (over-modulation) at a speed whose voltage with
     * the largest flux, psi_f + L i_max, would be 0.6 of the linear limit, the
     * error is the limit's: held where it was (r_cur; the EMF's checks judge
     * the loops' speed with no EMF measured, and flag) */
    in.u_limited = true;
    for (int k = 0; k < 300; ++k) fs_monitor_step(&m, &in);
    FS_CHECK(m.r_cur > 0.7f && m.r_cur < 0.76f, "0.5 i_max of error, the voltage short at speed: r_cur held at %g", m.r_cur);
    /* short at a speed whose voltage is at most 0.4 of it: not the speed's, counted */
    in.w = (float)(0.8 * w_half);
    for (int k = 0; k < 300; ++k) fs_monitor_step(&m, &in);
    FS_CHECK(m.r_cur > 1.1f, "0.5 i_max of error, short at 0.8 of that speed: r_cur %g", m.r_cur);
    in.w = 0.0f;
    for (int k = 0; k < 300; ++k) r = fs_monitor_step(&m, &in);
    in.u_limited = false;
    FS_CHECK(r > 1.1f, "0.5 i_max of error, short at standstill: r_cur %g", r);
    for (int k = 0; k < 300; ++k) r = fs_monitor_step(&m, &in);
    FS_CHECK(r > 1.1f, "0.5 i_max of error: r_cur %g", r);
    in.on = false;
    FS_CHECK(fs_monitor_step(&m, &in) == 0.0f && m.ierr_f == 0.0f && !m.started, "off: 0 and the filters rest");
    in.on = true;
    FS_CHECK(fs_monitor_step(&m, &in) == 0.0f, "back on: nothing before the filters warm up");
    /* the warm-up lasts two filter time constants (FS_MONITOR_WARM tau),
     * then the error is judged; the step count stops there however long the
     * drive runs (an int counting every step overflows after 2^31: 30 h at
     * 20 kHz) */
    int quiet = 1;
    while (quiet < 1000 && fs_monitor_step(&m, &in) == 0.0f) ++quiet;
    FS_CHECK(fabs(quiet - 2.0 * CFG.tau / CFG.Ts) <= 1.0, "judged after %d steps, 2 tau / Ts = %g", quiet,
             2.0 * CFG.tau / CFG.Ts);
    for (int k = 0; k < 10 * quiet; ++k) fs_monitor_step(&m, &in);
    FS_CHECK(m.k == m.n_warm && fs_monitor_step(&m, &in) > 1.1f, "the count held at %d (k %d), still judged", m.n_warm, m.k);

    /* refusals */
    fs_monitor_config c = CFG;
    c.Ts = 0.0f;
    FS_CHECK_EQ_INT(fs_monitor_init(&m, &c), FS_ERR_TS, "Ts 0");
    c = CFG;
    c.L_d = 0.0f;
    FS_CHECK_EQ_INT(fs_monitor_init(&m, &c), FS_ERR_LD, "L_d 0");
    c = CFG;
    c.delay = 3;
    FS_CHECK_EQ_INT(fs_monitor_init(&m, &c), FS_ERR_PARAM, "delay 3");
    c = CFG;
    c.tau = 0.5f * CFG.Ts;
    FS_CHECK_EQ_INT(fs_monitor_init(&m, &c), FS_ERR_LIMIT, "tau below Ts");
    c = CFG;
    c.i_max = NAN;
    FS_CHECK_EQ_INT(fs_monitor_init(&m, &c), FS_ERR_I_MAX, "i_max NaN");
    c = CFG;
    c.t_lost = 2.0f * CFG.Ts;
    FS_CHECK_EQ_INT(fs_monitor_init(&m, &c), FS_ERR_LIMIT, "t_lost below 4 Ts");
    c = CFG;
    c.w_h = -1.0f;
    FS_CHECK_EQ_INT(fs_monitor_init(&m, &c), FS_ERR_BANDWIDTH, "w_h negative");
    FS_CHECK_EQ_INT(fs_monitor_init(NULL, &CFG), FS_ERR_NULL, "null");
    return fs_test_summary("test_monitor");
}
