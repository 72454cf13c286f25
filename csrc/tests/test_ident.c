/* fs-test-sources: control/fs_ident.c control/fs_pi.c control/fs_transforms.c control/fs_status.c
 *
 * fs_ident's standstill steps against a locked-rotor R-L model in double
 * (d on alpha, one period of computation delay, a dead-time error of
 * u_e sign(i) per leg, exact discretization per axis): R_s, L_d, L_q and
 * the leg error come out within the goals, the q carrier on two d biases; and each trust check says why:
 * no current (an open circuit), the rotor moving (an EMF on q), a current
 * beyond i_max. A failed quantity takes every later one with it, and none
 * is OK after a failure it needs. Init refuses what the sequence cannot use.
 */
#include <math.h>

#include "control/fs_ident.h"
#include "tests/fs_test.h"

typedef struct {
    double R, L_d, L_q, u_e;   /* ohm, H, H, V per leg */
    double i_d, i_q;           /* state, rotor at 0: alpha = d */
    double u_a, u_b;           /* the voltage acting this period (delay 1) */
    double emf_q, w_emf;       /* an EMF amplitude on q at w_emf (the rotor swinging) */
    int open;                  /* an open circuit: no current ever */
    double t;
} rl_model;

static double sgn(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0); }

/* one period: the phase voltages less the legs' errors, each axis exact;
 * the legs switch at the period's middle, so the error's sign follows the
 * current there (predicted without the error) */
static void rl_step(rl_model *m, double Ts, fs_ab u_next)
{
    double ad = exp(-m->R * Ts / m->L_d), aq = exp(-m->R * Ts / m->L_q);
    double id_m = m->i_d + 0.5 * (1.0 - ad) * (m->u_a / m->R - m->i_d);
    double iq_m = m->i_q + 0.5 * (1.0 - aq) * (m->u_b / m->R - m->i_q);
    double i_a = id_m, i_b = -0.5 * id_m + 0.5 * sqrt(3.0) * iq_m, i_c = -0.5 * id_m - 0.5 * sqrt(3.0) * iq_m;
    double e_a = m->u_e * sgn(i_a), e_b = m->u_e * sgn(i_b), e_c = m->u_e * sgn(i_c);
    double ud = m->u_a - (2.0 / 3.0) * (e_a - 0.5 * (e_b + e_c));
    double uq = m->u_b - (e_b - e_c) / sqrt(3.0) - m->emf_q * sin(m->w_emf * m->t);
    m->i_d = m->open ? 0.0 : ad * m->i_d + (1.0 - ad) / m->R * ud;
    m->i_q = m->open ? 0.0 : aq * m->i_q + (1.0 - aq) / m->R * uq;
    m->u_a = u_next.alpha;
    m->u_b = u_next.beta;
    m->t += Ts;
}

static fs_ident make(float Ts, float i_max)
{
    fs_ident id;
    fs_ident_config c = {Ts, 1.0f, 4, i_max, 500.0f, 1.0f, 0.0f};
    fs_status st = fs_ident_init(&id, &c);
    FS_CHECK(st == FS_OK, "init: %s", fs_status_str(st));
    return id;
}

/* runs until the sequence leaves the standstill steps (or n_max samples) */
static void run(fs_ident *id, rl_model *m, double u_dc, int n_max, float i_extra)
{
    const float Ts = id->cfg.Ts;
    for (int k = 0; k < n_max && id->step < FS_IDENT_SPIN; ++k) {
        fs_ab i = {(float)m->i_d + i_extra, (float)m->i_q};
        fs_ab u = fs_ident_step(id, i, (float)u_dc);
        FS_CHECK(isfinite(u.alpha) && isfinite(u.beta), "finite voltage at sample %d", k);
        FS_CHECK(sqrtf(u.alpha * u.alpha + u.beta * u.beta) <= (float)(u_dc / sqrt(3.0)) * 1.0001f,
                 "within the linear range at sample %d", k);
        rl_step(m, Ts, u);
    }
}

int main(void)
{
    fs_ident id;
    fs_ident_config c = {1e-4f, 1.0f, 4, 10.0f, 500.0f, 1.0f, 0.0f};
    FS_CHECK_EQ_INT(fs_ident_init(NULL, &c), FS_ERR_NULL, "null");
    c.Ts = 0.0f;
    FS_CHECK_EQ_INT(fs_ident_init(&id, &c), FS_ERR_TS, "Ts 0");
    c.Ts = 1e-4f;
    c.delay = 0.5f;
    FS_CHECK_EQ_INT(fs_ident_init(&id, &c), FS_ERR_PARAM, "delay 0.5");
    c.delay = 1.0f;
    c.i_max = NAN;
    FS_CHECK_EQ_INT(fs_ident_init(&id, &c), FS_ERR_I_MAX, "i_max NaN");
    c.i_max = 10.0f;
    c.t_ramp = 50.0f * c.Ts;
    FS_CHECK_EQ_INT(fs_ident_init(&id, &c), FS_ERR_PARAM, "a ramp of 50 samples");
    c.t_ramp = 1.0f;
    c.pole_pairs = 0;
    FS_CHECK_EQ_INT(fs_ident_init(&id, &c), FS_ERR_POLE_PAIRS, "pole pairs 0");

    /* the standstill steps on a salient R-L load with a dead-time error */
    const double R = 0.5, L_d = 2e-3, L_q = 5e-3, u_e = 1.2, u_dc = 300.0;
    id = make(1e-4f, 10.0f);
    FS_CHECK(fs_ident_leg_error(&id, 5.0f) == 0.0f, "no leg error before it is measured");
    rl_model m = {R, L_d, L_q, u_e, 0, 0, 0, 0, 0, 0, 0, 0};
    run(&id, &m, u_dc, 200000, 0.0f);
    FS_CHECK_EQ_INT(id.step, FS_IDENT_SPIN, "the standstill steps finish");
    for (int q = FS_IDQ_VERR; q <= FS_IDQ_LQ; ++q)
        FS_CHECK_EQ_INT(id.res.status[q], FS_IDS_OK, "standstill quantity OK");
    FS_CHECK_EQ_INT(id.res.status[FS_IDQ_PSI_F], FS_IDS_PENDING, "psi_f not measured yet");
    FS_CHECK_REL(id.res.R_s, R, 0.01, 0.0, "R_s within 1 %");
    FS_CHECK_REL(id.res.L_d, L_d, 0.02, 0.0, "L_d within 2 %");
    FS_CHECK_REL(id.res.L_q, L_q, 0.02, 0.0, "L_q within 2 %");
    FS_CHECK_REL(id.res.u_e, u_e, 0.05, 0.0, "leg error within 5 %");
    FS_CHECK(fabsf(id.res.eps_align) < 0.02f, "no misalignment on a locked rotor at 0: %g", id.res.eps_align);
    /* the q carrier rides on two d biases within 0.2..0.8 i_max; a linear
     * load's L_q does not change with them */
    FS_CHECK(id.res.I_bias[0] >= 2.0f - 1e-4f && id.res.I_bias[1] == 2.0f * id.res.I_bias[0] && id.res.I_bias[1] <= 8.0f + 1e-4f,
             "biases %g, %g A", id.res.I_bias[0], id.res.I_bias[1]);
    FS_CHECK(fabsf(id.res.dL_q) * id.res.I_bias[1] < 0.01f * (float)L_q, "no L_q change with i_d: %g H/A", id.res.dL_q);
    FS_CHECK_NEAR(fs_ident_leg_error(&id, -5.0f), -fs_ident_leg_error(&id, 5.0f), 1e-6, "the leg error is odd");
    FS_CHECK(fabsf(id.L0 - (float)L_d) < (float)L_d, "the probe's L within a factor of two: %g", id.L0);

    /* an open circuit: the probe gives up, naming why; nothing is OK */
    id = make(1e-4f, 10.0f);
    m = (rl_model){R, L_d, L_q, u_e, 0, 0, 0, 0, 0, 0, 1, 0};
    run(&id, &m, u_dc, 200000, 0.0f);
    FS_CHECK_EQ_INT(id.step, FS_IDENT_FAILED, "open circuit fails");
    FS_CHECK_EQ_INT(id.res.reason[FS_IDQ_VERR], FS_IDR_NO_CURRENT, "open circuit: no current");
    for (int q = 0; q < FS_IDQ_N; ++q) {
        FS_CHECK_EQ_INT(id.res.status[q], FS_IDS_FAILED, "every quantity failed");
        if (q != FS_IDQ_VERR) FS_CHECK_EQ_INT(id.res.reason[q], FS_IDR_PREREQ, "the rest for want of it");
    }
    FS_CHECK(fs_ident_reason_str(FS_IDR_NO_CURRENT)[0] != '\0', "a reason has a text");

    /* a rotor that keeps swinging (an EMF on q): the alignment never settles */
    id = make(1e-4f, 10.0f);
    m = (rl_model){R, L_d, L_q, u_e, 0, 0, 0, 0, 2.0, 60.0, 0, 0};
    run(&id, &m, u_dc, 200000, 0.0f);
    FS_CHECK_EQ_INT(id.step, FS_IDENT_FAILED, "a moving rotor fails");
    FS_CHECK_EQ_INT(id.res.reason[FS_IDQ_VERR], FS_IDR_MOVED, "a moving rotor: moved");
    FS_CHECK_EQ_INT(id.res.status[FS_IDQ_RS], FS_IDS_FAILED, "no R_s from a moving rotor");

    /* a current reading beyond i_max (a sensor offset of 12 A on 10) */
    id = make(1e-4f, 10.0f);
    m = (rl_model){R, L_d, L_q, u_e, 0, 0, 0, 0, 0, 0, 0, 0};
    run(&id, &m, u_dc, 1000, 12.0f);
    FS_CHECK_EQ_INT(id.step, FS_IDENT_FAILED, "overcurrent fails");
    FS_CHECK_EQ_INT(id.res.reason[FS_IDQ_VERR], FS_IDR_OVERCURRENT, "overcurrent named");

    /* no link: the sequence waits */
    id = make(1e-4f, 10.0f);
    fs_ab u = fs_ident_step(&id, (fs_ab){0.0f, 0.0f}, 0.0f);
    FS_CHECK(id.step == FS_IDENT_START && u.alpha == 0.0f && u.beta == 0.0f, "waits for the dc link");
    return fs_test_summary("test_ident");
}
