/* fs-test-sources: control/fs_ident.c control/fs_mapid.c control/fs_pi.c control/fs_transforms.c control/fs_status.c
 *
 * fs_ident's standstill steps against a locked-rotor R-L model in double
 * (its d axis at theta_r, one period of computation delay, a dead-time
 * error of u_e sign(i) per leg, exact discretization per axis): AXIS finds
 * the rotor's axis, R_s, L_d, L_q and the leg error come out within the
 * goals, the q carrier on two d biases, and MAP reads the linear load's
 * flux; a locked rotor ends after the standstill steps with the running
 * quantities skipped for that reason; and each trust check says why: no
 * current (an open circuit), the rotor moving (an EMF on q), a current
 * beyond i_max. A failed quantity takes every later one with it, and none
 * is OK after a failure it needs. Init refuses what the sequence cannot use.
 */
#include <math.h>

#include "control/fs_ident.h"
#include "tests/fs_test.h"

typedef struct {
    double R, L_d, L_q, u_e;   /* ohm, H, H, V per leg */
    double i_d, i_q;           /* state, in the rotor's frame */
    double u_a, u_b;           /* the voltage acting this period (delay 1), in the rotor's frame */
    double emf_q, w_emf;       /* an EMF amplitude on q at w_emf (the rotor swinging) */
    int open;                  /* an open circuit: no current ever */
    double t;
    double theta_r;            /* el. rad: the rotor's d axis (locked there) */
} rl_model;

#define PI 3.14159265358979323846

static double sgn(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0); }

/* one period: the phase voltages less the legs' errors, each axis exact;
 * the legs switch at the period's middle, so the error's sign follows the
 * current there (predicted without the error) */
static void rl_step(rl_model *m, double Ts, fs_ab u_next)
{
    const double c = cos(m->theta_r), s = sin(m->theta_r);
    double ad = exp(-m->R * Ts / m->L_d), aq = exp(-m->R * Ts / m->L_q);
    double id_m = m->i_d + 0.5 * (1.0 - ad) * (m->u_a / m->R - m->i_d);
    double iq_m = m->i_q + 0.5 * (1.0 - aq) * (m->u_b / m->R - m->i_q);
    double ia_m = c * id_m - s * iq_m, ib_m = s * id_m + c * iq_m;   /* stationary */
    double i_a = ia_m, i_b = -0.5 * ia_m + 0.5 * sqrt(3.0) * ib_m, i_c = -0.5 * ia_m - 0.5 * sqrt(3.0) * ib_m;
    double e_a = m->u_e * sgn(i_a), e_b = m->u_e * sgn(i_b), e_c = m->u_e * sgn(i_c);
    double e_al = (2.0 / 3.0) * (e_a - 0.5 * (e_b + e_c)), e_be = (e_b - e_c) / sqrt(3.0);
    double ud = m->u_a - (c * e_al + s * e_be);
    double uq = m->u_b - (-s * e_al + c * e_be) - m->emf_q * sin(m->w_emf * m->t);
    m->i_d = m->open ? 0.0 : ad * m->i_d + (1.0 - ad) / m->R * ud;
    m->i_q = m->open ? 0.0 : aq * m->i_q + (1.0 - aq) / m->R * uq;
    m->u_a = c * u_next.alpha + s * u_next.beta;   /* the next period's, in the rotor's frame */
    m->u_b = -s * u_next.alpha + c * u_next.beta;
    m->t += Ts;
}

static fs_ident_config config(float Ts, float i_max)
{
    return (fs_ident_config){.Ts = Ts, .delay = 1.0f, .pole_pairs = 4, .i_max = i_max, .w_spin = 500.0f, .t_ramp = 1.0f};
}

static fs_ident make_with(const fs_ident_config *c)
{
    fs_ident id;
    fs_status st = fs_ident_init(&id, c);
    FS_CHECK(st == FS_OK, "init: %s", fs_status_str(st));
    return id;
}

static fs_ident make(float Ts, float i_max)
{
    const fs_ident_config c = config(Ts, i_max);
    return make_with(&c);
}

/* runs until the sequence leaves the standstill steps (or n_max samples) */
static void run(fs_ident *id, rl_model *m, double u_dc, int n_max, float i_extra)
{
    const float Ts = id->cfg.Ts;
    for (int k = 0; k < n_max && id->step < FS_IDENT_SPIN; ++k) {
        const double c = cos(m->theta_r), s = sin(m->theta_r);
        fs_ab i = {(float)(c * m->i_d - s * m->i_q) + i_extra, (float)(s * m->i_d + c * m->i_q)};
        fs_ab u = fs_ident_step(id, i, (float)u_dc);
        FS_CHECK(isfinite(u.alpha) && isfinite(u.beta), "finite voltage at sample %d", k);
        FS_CHECK(sqrtf(u.alpha * u.alpha + u.beta * u.beta) <= (float)(u_dc / sqrt(3.0)) * 1.0001f,
                 "within the linear range at sample %d", k);
        rl_step(m, Ts, u);
    }
}

/* the angle between two axes, modulo pi, rad */
static double axis_diff(double a, double b)
{
    double d = fmod(a - b, PI);
    if (d > 0.5 * PI) d -= PI;
    if (d < -0.5 * PI) d += PI;
    return d;
}

int main(void)
{
    fs_ident id;
    fs_ident_config c = config(1e-4f, 10.0f);
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
    c.pole_pairs = 4;
    c.i_test = 12.0f;
    FS_CHECK_EQ_INT(fs_ident_init(&id, &c), FS_ERR_PARAM, "a test current above i_max");
    c.i_test = 0.0f;
    c.locked = 2;
    FS_CHECK_EQ_INT(fs_ident_init(&id, &c), FS_ERR_PARAM, "locked neither 0 nor 1");

    /* the standstill steps on a salient R-L load with a dead-time error, its d axis on alpha (where
     * ALIGN puts a free rotor: the linear load shows no polarity) */
    const double R = 0.5, L_d = 2e-3, L_q = 5e-3, u_e = 1.2, u_dc = 300.0, th = 30.0 * PI / 180.0;
    id = make(1e-4f, 10.0f);
    FS_CHECK(fs_ident_leg_error(&id, 5.0f) == 0.0f, "no leg error before it is measured");
    rl_model m = {R, L_d, L_q, u_e, 0, 0, 0, 0, 0, 0, 0, 0, 0.0};
    run(&id, &m, u_dc, 400000, 0.0f);
    FS_CHECK_EQ_INT(id.step, FS_IDENT_SPIN, "the standstill steps finish");
    for (int q = FS_IDQ_VERR; q <= FS_IDQ_MAP; ++q)
        FS_CHECK(id.res.status[q] == FS_IDS_OK, "standstill quantity %d OK (reason %d)", q, id.res.reason[q]);
    FS_CHECK_EQ_INT(id.res.status[FS_IDQ_PSI_F], FS_IDS_PENDING, "psi_f not measured yet");
    FS_CHECK(fabs(id.res.theta_axis) < 0.5 * PI / 180.0, "the axis within 0.5 deg: %g deg", id.res.theta_axis * 180.0 / PI);
    FS_CHECK_NEAR(id.res.saliency, (L_q - L_d) / (L_q + L_d), 0.03, "the saliency");
    FS_CHECK_REL(id.res.R_s, R, 0.01, 0.0, "R_s within 1 %");
    FS_CHECK_REL(id.res.L_d, L_d, 0.02, 0.0, "L_d within 2 %");
    FS_CHECK_REL(id.res.L_q, L_q, 0.02, 0.0, "L_q within 2 %");
    FS_CHECK_REL(id.res.u_e, u_e, 0.05, 0.0, "leg error within 5 %");
    FS_CHECK(fabsf(id.res.eps_align) < 0.02f, "no misalignment on a locked rotor: %g", id.res.eps_align);
    /* no saturation: the polarity is not seen, and a rotor that may turn is aligned (ALIGN ran) */
    FS_CHECK(!id.res.pol_decided && id.res.n_step[FS_IDENT_ALIGN] > 0, "linear: polarity undecided (%g), ALIGN ran",
             id.res.pol_asym);
    /* the q carrier rides on two d biases within 0.2..0.8 i_max; a linear
     * load's L_q does not change with them */
    FS_CHECK(id.res.I_bias[0] >= 2.0f - 1e-4f && id.res.I_bias[1] == 2.0f * id.res.I_bias[0] && id.res.I_bias[1] <= 8.0f + 1e-4f,
             "biases %g, %g A", id.res.I_bias[0], id.res.I_bias[1]);
    FS_CHECK(fabsf(id.res.dL_q) * id.res.I_bias[1] < 0.01f * (float)L_q, "no L_q change with i_d: %g H/A", id.res.dL_q);
    FS_CHECK_NEAR(fs_ident_leg_error(&id, -5.0f), -fs_ident_leg_error(&id, 5.0f), 1e-6, "the leg error is odd");
    FS_CHECK(fabsf(id.L0 - (float)L_d) < (float)L_d, "the probe's L within a factor of two: %g", id.L0);
    /* the map: the linear load's flux, within 1 % of L i_max, on the d axis and on q at zero d */
    for (int k = 0; k < FS_MAPID_ND; ++k)
        FS_CHECK(fabs(id.map.res.dpsi_d[k] - L_d * 2.5 * (k - 4)) < 0.01 * L_d * 10.0, "psi_d at %g A: %g", 2.5 * (k - 4),
                 id.map.res.dpsi_d[k]);
    for (int j = 1; j <= FS_MAPID_NQ; ++j)
        if (id.map.res.n_q[4][j - 1] > 0)
            FS_CHECK(fabs(id.map.res.psi_q[4][j - 1] - L_q * 1.25 * j) < 0.01 * L_q * 10.0, "psi_q at %g A: %g", 1.25 * j,
                     id.map.res.psi_q[4][j - 1]);
    FS_CHECK(id.map.res.n_q[4][3] > 0, "the q sweep at zero d read at least to i_max / 2");
    /* the steps in the order they ran, CHECK twice, the map between */
    FS_CHECK(id.res.n_visit >= 8 && id.res.visit_step[0] == FS_IDENT_PROBE && id.res.visit_at[0] > 0,
             "the visits recorded: %d", id.res.n_visit);
    int at_map = -1, checks = 0;
    for (int v = 0; v < id.res.n_visit; ++v) {
        if (id.res.visit_step[v] == FS_IDENT_MAP) at_map = v;
        checks += id.res.visit_step[v] == FS_IDENT_CHECK;
        if (v) FS_CHECK(id.res.visit_at[v] >= id.res.visit_at[v - 1], "visits in time order");
    }
    FS_CHECK(at_map > 0 && checks == 2 && id.res.visit_step[at_map - 1] == FS_IDENT_CHECK
             && id.res.visit_step[at_map + 1] == FS_IDENT_CHECK, "CHECK before and after MAP");

    /* the rotor held off the axis ALIGN turns a free one to (30 deg): the misalignment named */
    id = make(1e-4f, 10.0f);
    m = (rl_model){R, L_d, L_q, u_e, 0, 0, 0, 0, 0, 0, 0, 0, th};
    run(&id, &m, u_dc, 400000, 0.0f);
    FS_CHECK_EQ_INT(id.step, FS_IDENT_FAILED, "held off the alignment: failed");
    FS_CHECK_EQ_INT(id.res.reason[FS_IDQ_LD], FS_IDR_MISALIGNED, "held off the alignment: named");
    FS_CHECK(fabs(fabs(id.res.eps_align) - th) < 0.1, "the misalignment seen: %g deg", id.res.eps_align * 180.0 / PI);

    /* a locked rotor (d axis at -30 deg): AXIS finds it, the polarity unknown the levels alternate (no
     * ALIGN), and the sequence ends after the standstill steps with the running quantities skipped, saying why */
    c = config(1e-4f, 10.0f);
    c.locked = 1;
    id = make_with(&c);
    m = (rl_model){R, L_d, L_q, u_e, 0, 0, 0, 0, 0, 0, 0, 0, -th};
    run(&id, &m, u_dc, 400000, 0.0f);
    FS_CHECK_EQ_INT(id.step, FS_IDENT_DONE, "locked: done after the standstill steps");
    FS_CHECK_EQ_INT(id.res.n_step[FS_IDENT_ALIGN], 0, "locked: no alignment");
    FS_CHECK(fabs(axis_diff(id.res.theta_axis, -th)) < 0.5 * PI / 180.0, "locked: the axis within 0.5 deg: %g deg",
             id.res.theta_axis * 180.0 / PI);
    FS_CHECK(id.res.I_levn[0] < -0.5f * id.res.i_level_top, "locked: the levels at -I too (%g A)", id.res.I_levn[0]);
    FS_CHECK_REL(id.res.L_d, L_d, 0.02, 0.0, "locked: L_d within 2 %");
    FS_CHECK_REL(id.res.R_s, R, 0.01, 0.0, "locked: R_s within 1 %");
    FS_CHECK_REL(id.res.L_q, L_q, 0.02, 0.0, "locked: L_q within 2 %");
    FS_CHECK_EQ_INT(id.res.status[FS_IDQ_MAP], FS_IDS_OK, "locked: the map");
    for (int q = FS_IDQ_PSI_F; q <= FS_IDQ_FRICTION; ++q) {
        FS_CHECK(id.res.status[q] == FS_IDS_SKIPPED, "locked: quantity %d skipped", q);
        FS_CHECK_EQ_INT(id.res.reason[q], FS_IDR_LOCKED, "locked: the reason");
    }

    /* no map asked for: skipped, the rest as before */
    c = config(1e-4f, 10.0f);
    c.skip_map = 1;
    id = make_with(&c);
    m = (rl_model){R, L_d, L_q, u_e, 0, 0, 0, 0, 0, 0, 0, 0, 0.0};
    run(&id, &m, u_dc, 400000, 0.0f);
    FS_CHECK_EQ_INT(id.step, FS_IDENT_SPIN, "no map: on to SPIN");
    FS_CHECK(id.res.status[FS_IDQ_MAP] == FS_IDS_SKIPPED && id.res.reason[FS_IDQ_MAP] == FS_IDR_NOT_ASKED, "no map: skipped");
    FS_CHECK_EQ_INT(id.res.n_step[FS_IDENT_MAP], 0, "no map: MAP not run");
    FS_CHECK_REL(id.res.L_d, L_d, 0.02, 0.0, "no map: L_d within 2 %");

    /* an open circuit: the probe gives up, naming why; nothing is OK */
    id = make(1e-4f, 10.0f);
    m = (rl_model){R, L_d, L_q, u_e, 0, 0, 0, 0, 0, 0, 1, 0, 0};
    run(&id, &m, u_dc, 200000, 0.0f);
    FS_CHECK_EQ_INT(id.step, FS_IDENT_FAILED, "open circuit fails");
    FS_CHECK_EQ_INT(id.res.reason[FS_IDQ_VERR], FS_IDR_NO_CURRENT, "open circuit: no current");
    for (int q = 0; q < FS_IDQ_N; ++q) {
        FS_CHECK_EQ_INT(id.res.status[q], FS_IDS_FAILED, "every quantity failed");
        if (q != FS_IDQ_VERR) FS_CHECK_EQ_INT(id.res.reason[q], FS_IDR_PREREQ, "the rest for want of it");
    }
    FS_CHECK(fs_ident_reason_str(FS_IDR_NO_CURRENT)[0] != '\0', "a reason has a text");

    /* a rotor that keeps swinging (an EMF on q): a step finds it moving and says so */
    id = make(1e-4f, 10.0f);
    m = (rl_model){R, L_d, L_q, u_e, 0, 0, 0, 0, 2.0, 60.0, 0, 0, 0};
    run(&id, &m, u_dc, 400000, 0.0f);
    FS_CHECK_EQ_INT(id.step, FS_IDENT_FAILED, "a moving rotor fails");
    FS_CHECK_EQ_INT(id.res.reason[FS_IDQ_VERR], FS_IDR_MOVED, "a moving rotor: moved");
    FS_CHECK_EQ_INT(id.res.status[FS_IDQ_RS], FS_IDS_FAILED, "no R_s from a moving rotor");

    /* a current reading beyond i_max (a sensor offset of 12 A on 10) */
    id = make(1e-4f, 10.0f);
    m = (rl_model){R, L_d, L_q, u_e, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    run(&id, &m, u_dc, 1000, 12.0f);
    FS_CHECK_EQ_INT(id.step, FS_IDENT_FAILED, "overcurrent fails");
    FS_CHECK_EQ_INT(id.res.reason[FS_IDQ_VERR], FS_IDR_OVERCURRENT, "overcurrent named");

    /* no link: the sequence waits */
    id = make(1e-4f, 10.0f);
    fs_ab u = fs_ident_step(&id, (fs_ab){0.0f, 0.0f}, 0.0f);
    FS_CHECK(id.step == FS_IDENT_START && u.alpha == 0.0f && u.beta == 0.0f, "waits for the dc link");
    return fs_test_summary("test_ident");
}
