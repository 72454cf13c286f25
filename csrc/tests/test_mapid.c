/* fs-test-sources: control/fs_mapid.c control/fs_pi.c control/fs_transforms.c control/fs_status.c plant/fs_magnetic.c
 *
 * fs_mapid's sweeps against a locked rotor in double with the algebraic
 * magnetics of fs_magnetic.h (self- and cross-saturation, the magnet's
 * asymmetry), fluxes as the states, one period of computation delay and a
 * dead-time error of u_e sign(i) per leg that the caller does not model
 * (so the crossings' averages must take it out): the d axis and the q
 * sweeps read the map within 1 % of psi_f; a frame on the magnet's south
 * pole is found by the d axis' asymmetry and turned; the motion bound
 * shortens the q sweeps of a light rotor, and a voltage too low for them
 * stops them short, each with the reason.
 */
#include <math.h>

#include "control/fs_mapid.h"
#include "plant/fs_magnetic.h"
#include "tests/fs_test.h"

typedef struct {
    fs_mag mag;
    double R, u_e;
    double psi_d, psi_q;   /* states, rotor frame */
    double u_d, u_q;       /* the voltage acting this period (delay 1) */
    double sgn;            /* the caller's frame: +1 on the north pole, -1 on the south */
} plant;

static double sgn(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0); }

static void currents(plant *p, double *i_d, double *i_q) { fs_mag_current(&p->mag, p->psi_d, p->psi_q, i_d, i_q); }

/* one period in 20 sub-steps: the phase voltages less the legs' errors */
static void plant_step(plant *p, double Ts, fs_dq u_next)
{
    for (int s = 0; s < 20; ++s) {
        double i_d, i_q;
        currents(p, &i_d, &i_q);
        /* the legs: d on phase a */
        const double i_a = i_d, i_b = -0.5 * i_d + 0.5 * sqrt(3.0) * i_q, i_c = -0.5 * i_d - 0.5 * sqrt(3.0) * i_q;
        const double e_a = p->u_e * sgn(i_a), e_b = p->u_e * sgn(i_b), e_c = p->u_e * sgn(i_c);
        const double ed = (2.0 / 3.0) * (e_a - 0.5 * (e_b + e_c)), eq = (e_b - e_c) / sqrt(3.0);
        p->psi_d += Ts / 20.0 * (p->u_d - ed - p->R * i_d);
        p->psi_q += Ts / 20.0 * (p->u_q - eq - p->R * i_q);
    }
    p->u_d = p->sgn * u_next.d;
    p->u_q = p->sgn * u_next.q;
}

static plant make_plant(double sign)
{
    plant p = {0};
    fs_mag_config mc = {0};
    mc.kind = FS_MAG_ALGEBRAIC;
    mc.L_d = 2e-3;
    mc.L_q = 5e-3;
    mc.psi_f = 0.1;
    mc.a_dd = 4e9;   /* the incremental L_d about 25 % lower at +10 A */
    mc.S = 8.0;
    mc.a_dq = 3e6;   /* cross-saturation */
    mc.U = 2.0;
    mc.V = 1.0;
    FS_CHECK(fs_mag_init(&p.mag, &mc) == FS_OK, "magnetics");
    fs_mag_flux(&p.mag, 0.0, 0.0, &p.psi_d, &p.psi_q);
    p.R = 0.3;
    p.u_e = 1.5;
    p.sgn = sign;
    return p;
}

static fs_mapid make(float i_max, float psi_f, float J, float motion)
{
    fs_mapid m;
    fs_mapid_config c = {1e-4f, 1.0f, i_max, 2e-3f, 5e-3f, 0.3f, 1.5f, 4, psi_f, J, motion, 1000.0f, 0, 0};
    FS_CHECK(fs_mapid_init(&m, &c) == FS_OK, "init");
    return m;
}

/* the caller's model of the inverter's error: 90 % of it, with a knee of 0.2 A (fs_ident's fitted leg error) */
static fs_dq error_model(const plant *p, fs_dq i)
{
    const double i_a = i.d, i_b = -0.5 * i.d + 0.5 * sqrt(3.0) * i.q, i_c = -0.5 * i.d - 0.5 * sqrt(3.0) * i.q;
#define G(x) (0.9 * p->u_e * (x) / sqrt((x) * (x) + 0.04))
    const double e_a = G(i_a), e_b = G(i_b), e_c = G(i_c);
#undef G
    return (fs_dq){(float)((2.0 / 3.0) * (e_a - 0.5 * (e_b + e_c))), (float)((e_b - e_c) / sqrt(3.0))};
}

static int run(fs_mapid *m, plant *p, double u_dc, int n_max)
{
    int k = 0;
    for (; k < n_max && m->stage != FS_MAPID_DONE; ++k) {
        double i_d, i_q;
        currents(p, &i_d, &i_q);
        const fs_dq i = {(float)(p->sgn * i_d), (float)(p->sgn * i_q)};
        const fs_dq e = error_model(p, i);
        const fs_dq u = fs_mapid_step(m, i, e, (float)(u_dc / sqrt(3.0)));
        FS_CHECK(isfinite(u.d) && isfinite(u.q), "finite at %d", k);
        FS_CHECK(sqrt(i_d * i_d + i_q * i_q) < 1.1 * m->cfg.i_max, "within 1.1 i_max at %d: %g, %g", k, i_d, i_q);
        plant_step(p, m->cfg.Ts, u);
    }
    return k;
}

static void check_map(const fs_mapid *m, plant *p, const char *what)
{
    const fs_mapid_result *r = &m->res;
    const double i_max = m->cfg.i_max, psi_f = 0.1;
    double pd0, pq0;
    fs_mag_flux(&p->mag, 0.0, 0.0, &pd0, &pq0);
    for (int k = 0; k < FS_MAPID_ND; ++k) {
        const double I = 0.25 * (k - 4) * i_max;
        double pd, pq;
        fs_mag_flux(&p->mag, I, 0.0, &pd, &pq);
        FS_CHECK(r->n_d[k] > 0, "%s: d axis read at %g A", what, I);
        FS_CHECK_NEAR(r->dpsi_d[k], pd - pd0, 0.01 * psi_f, what);
    }
    int n = 0;
    for (int k = 0; k < FS_MAPID_ND; ++k) {
        for (int j = 1; j <= FS_MAPID_NQ; ++j) {
            if (!r->n_q[k][j - 1]) continue;
            ++n;
            const double I_d = r->i_d_at[k][j - 1], I_q = 0.125 * j * i_max;
            double pd, pq, pd0q, pq0q;
            fs_mag_flux(&p->mag, I_d, I_q, &pd, &pq);
            fs_mag_flux(&p->mag, I_d, 0.0, &pd0q, &pq0q);
            FS_CHECK(fabs(I_d - 0.25 * (k - 4) * i_max) < 0.04 * i_max, "%s: the level held: %g", what, I_d);
            FS_CHECK_NEAR(r->psi_q[k][j - 1], pq, 0.01 * psi_f, what);
            FS_CHECK_NEAR(r->dpsi_dq[k][j - 1], pd - pd0q, 0.01 * psi_f, what);
        }
    }
    FS_CHECK(n >= 30, "%s: the q sweeps read %d points", what, n);
}

int main(void)
{
    fs_mapid m;
    fs_mapid_config c = {1e-4f, 1.0f, 10.0f, 2e-3f, 5e-3f, 0.3f, 1.5f, 4, 0.1f, 1e-3f, 0.0175f, 1000.0f, 0, 0};
    FS_CHECK_EQ_INT(fs_mapid_init(NULL, &c), FS_ERR_NULL, "null");
    c.L_q = 0.0f;
    FS_CHECK_EQ_INT(fs_mapid_init(&m, &c), FS_ERR_LQ, "L_q 0");
    c.L_q = 5e-3f;
    c.delay = 2.0f;
    FS_CHECK_EQ_INT(fs_mapid_init(&m, &c), FS_ERR_PARAM, "delay 2");

    /* a locked rotor (no motion bound), the frame on the north pole */
    const float i_max = 10.0f;
    m = make(i_max, 0.0f, 0.0f, 0.0f);
    plant p = make_plant(1.0);
    int n = run(&m, &p, 300.0, 200000);
    FS_CHECK_EQ_INT(m.stage, FS_MAPID_DONE, "the sweeps finish");
    FS_CHECK(n < 20000, "within 2 s: %d samples", n);
    FS_CHECK(!m.res.flipped && m.res.asym > 0.05f, "on the north pole: asymmetry %g", m.res.asym);
    check_map(&m, &p, "north");
    for (int k = 0; k < FS_MAPID_ND; ++k)
        FS_CHECK(m.res.limit[k] == FS_MAPID_LIM_DISC, "locked: the disc bounds level %d", k);

    /* the frame on the south pole: found and turned, the map the same */
    m = make(i_max, 0.0f, 0.0f, 0.0f);
    p = make_plant(-1.0);
    run(&m, &p, 300.0, 200000);
    FS_CHECK(m.res.flipped && m.res.asym > 0.05f, "on the south pole: turned, asymmetry %g", m.res.asym);
    check_map(&m, &p, "south");

    /* the polarity given (ALIGN's): the south's asymmetry reported, the frame never turned */
    m = make(i_max, 0.0f, 0.0f, 0.0f);
    m.cfg.pol_known = 1;
    p = make_plant(-1.0);
    run(&m, &p, 300.0, 200000);
    FS_CHECK(!m.res.flipped && m.res.decided && m.res.asym < -0.05f, "polarity given: not turned, asymmetry %g", m.res.asym);

    /* a light rotor: the q sweeps shortened by the motion bound */
    m = make(i_max, 0.1f, 2e-5f, 0.0175f);
    p = make_plant(1.0);
    run(&m, &p, 300.0, 200000);
    int motion = 0;
    for (int k = 0; k < FS_MAPID_ND; ++k) {
        if (m.res.i_q_amp[k] <= 0.0f) continue;
        FS_CHECK(m.res.motion[k] <= 0.0175f * 1.001f, "level %d: motion %g within the bound", k, m.res.motion[k]);
        motion += m.res.limit[k] != FS_MAPID_LIM_DISC;
    }
    FS_CHECK(motion > 0, "the bound shortened some sweep");
    /* its d sweep: faster, and cut (or left out) where the free rotor would turn away more than threefold */
    FS_CHECK(m.res.d_limit == FS_MAPID_LIM_UNSTABLE && m.res.d_amp < 1.03f * i_max, "the d sweep cut: %g A", m.res.d_amp);
    FS_CHECK(m.res.d_amp == 0.0f || coshf(m.res.d_growth) <= 3.0f * 1.001f, "its growth within threefold: %g", m.res.d_growth);
    /* a heavier rotor: the d sweep to the disc's edge, its growth within the bound */
    m = make(i_max, 0.1f, 1e-2f, 0.0175f);
    p = make_plant(1.0);
    run(&m, &p, 300.0, 200000);
    FS_CHECK(m.res.d_limit == FS_MAPID_LIM_DISC && m.res.d_amp > i_max, "a heavy rotor: the whole d axis (%g A)", m.res.d_amp);
    FS_CHECK(m.res.d_growth > 0.0f && coshf(m.res.d_growth) <= 3.0f, "a heavy rotor: growth %g", m.res.d_growth);

    /* a low link: the voltage stops the sweeps short of the disc */
    m = make(i_max, 0.0f, 0.0f, 0.0f);
    p = make_plant(1.0);
    run(&m, &p, 20.0, 400000);
    FS_CHECK_EQ_INT(m.stage, FS_MAPID_DONE, "a low link still finishes");
    FS_CHECK(m.res.limit[FS_MAPID_ND / 2] == FS_MAPID_LIM_VOLTAGE, "the voltage names the limit: %d", m.res.limit[FS_MAPID_ND / 2]);
    return fs_test_summary("test_mapid");
}
