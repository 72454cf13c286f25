/* fs-test-sources: control/fs_swvi.c control/fs_pll.c control/fs_xcomp.c control/fs_transforms.c control/fs_status.c
 *
 * The square-wave injection estimator (yu2022) against an independent model:
 * a salient PMSM with optional cross-coupling inductance L_dq, flux states
 * in rotor coordinates integrated by RK4 in 20 sub-steps per period, turning
 * at an imposed speed, driven by the held voltages of a drive with one
 * period of computation delay. The fundamental voltage cancels the back-EMF
 * and is held over each window (k, k + 2), k even, as the drive holds it.
 *
 * Checks: the extracted amplitudes against eq. (5); lock from an initial
 * error; the optimized sequence's steady error -1.5 w_e Ts, eq. (18), at two
 * speeds; the conventional sequence's lag and its value from the
 * common-mode leak; cross-saturation: the PLL on the HF axis theta +
 * delta, delta = -phi_dq / 2 (eq. (21)), and the compensation taking it out;
 * eq. (22)'s cubic; init refusals.
 */
#include <math.h>
#include <string.h>

#include "control/fs_swvi.h"
#include "tests/fs_test.h"

#define PI 3.14159265358979323846
#define TS 125e-6
#define R_S 0.5
#define L_D 11.8e-3
#define L_Q 13.7e-3
#define PSI_F 0.098
#define U_H 60.0
#define SUB 20

typedef struct {
    double w_e, theta0, L_dq;      /* imposed speed, initial angle, cross-coupling inductance */
    int sequence;
    double pll_err0;               /* the PLL starts at theta0 - pll_err0 */
    double duration;
    fs_xcomp_config xcomp;
} scen;

typedef struct {
    double err_mean, err_max;      /* theta_r - theta_out over the last third */
    double pll_err_mean;           /* theta_r - theta_pll (before compensation) */
    double I_dh, I_qh;             /* mean extracted amplitudes, last third */
    fs_swvi s;
} result;

/* Currents of the rotor-frame fluxes: psi = L i + (psi_f, 0), L = [L_d L_dq; L_dq L_q]. */
static void currents(double L_dq, double pd, double pq, double *id, double *iq)
{
    double det = L_D * L_Q - L_dq * L_dq, a = pd - PSI_F;
    *id = (L_Q * a - L_dq * pq) / det;
    *iq = (L_D * pq - L_dq * a) / det;
}

static void deriv(const scen *sc, double th, const double x[2], double ua, double ub, double dx[2])
{
    double id, iq, c = cos(th), s = sin(th);
    currents(sc->L_dq, x[0], x[1], &id, &iq);
    double ud = c * ua + s * ub, uq = -s * ua + c * ub;
    dx[0] = ud - R_S * id + sc->w_e * x[1];
    dx[1] = uq - R_S * iq - sc->w_e * x[0];
}

static void run(const scen *sc, result *r)
{
    fs_swvi_config c;
    memset(&c, 0, sizeof c);
    c.Ts = (float)TS; c.delay = 1; c.u_h = (float)U_H; c.L_d = (float)L_D; c.L_q = (float)L_Q;
    c.bandwidth = 57.5f; c.sequence = sc->sequence; c.xcomp = sc->xcomp;
    FS_CHECK_EQ_INT(fs_swvi_init(&r->s, &c), FS_OK, "init");
    fs_swvi_reset(&r->s, (float)(sc->theta0 - sc->pll_err0), (float)sc->w_e);
    double x[2] = {PSI_F, 0.0}, th = sc->theta0;
    double u_next[2] = {0, 0}, u_now[2] = {0, 0};
    int n = (int)(sc->duration / TS), n0 = 2 * n / 3, cnt = 0;
    double se = 0, sp = 0, emax = 0, sd = 0, sq = 0;
    int nh = 0;
    for (int k = 0; k < n; ++k) {
        double id, iq;
        currents(sc->L_dq, x[0], x[1], &id, &iq);
        fs_ab i = {(float)(cos(th) * id - sin(th) * iq), (float)(sin(th) * id + cos(th) * iq)};
        fs_swvi_step(&r->s, i);
        if (k >= n0) {
            double e = remainder(th - r->s.theta, 2 * PI), ep = remainder(th - r->s.pll.theta, 2 * PI);
            se += e; sp += ep; ++cnt;
            if (fabs(e) > emax) emax = fabs(e);
            if (r->s.ff_fresh) { sd += r->s.i_h.d; sq += r->s.i_h.q; ++nh; }
        }
        /* the voltage computed now acts over (k+1, k+2): the carrier, and the
         * back-EMF at the middle of its window (j - j mod 2, + 2) */
        int j = k + 1;
        double thm = th + sc->w_e * TS * ((j - j % 2) - k + 1);
        u_next[0] = r->s.u.alpha - sc->w_e * PSI_F * sin(thm);
        u_next[1] = r->s.u.beta + sc->w_e * PSI_F * cos(thm);
        /* the period (k, k+1) with the voltage computed at k - 1 */
        for (int m = 0; m < SUB; ++m) {
            double h = TS / SUB, k1[2], k2[2], k3[2], k4[2], y[2];
            deriv(sc, th, x, u_now[0], u_now[1], k1);
            for (int q = 0; q < 2; ++q) y[q] = x[q] + 0.5 * h * k1[q];
            deriv(sc, th + 0.5 * h * sc->w_e, y, u_now[0], u_now[1], k2);
            for (int q = 0; q < 2; ++q) y[q] = x[q] + 0.5 * h * k2[q];
            deriv(sc, th + 0.5 * h * sc->w_e, y, u_now[0], u_now[1], k3);
            for (int q = 0; q < 2; ++q) y[q] = x[q] + h * k3[q];
            deriv(sc, th + h * sc->w_e, y, u_now[0], u_now[1], k4);
            for (int q = 0; q < 2; ++q) x[q] += h / 6 * (k1[q] + 2 * k2[q] + 2 * k3[q] + k4[q]);
            th += h * sc->w_e;
        }
        u_now[0] = u_next[0]; u_now[1] = u_next[1];
    }
    r->err_mean = se / cnt;
    r->pll_err_mean = sp / cnt;
    r->err_max = emax;
    r->I_dh = sd / nh;
    r->I_qh = sq / nh;
}

int main(void)
{
    const double k_norm = L_D * L_Q / (TS * U_H * (L_Q - L_D));
    scen s0;
    memset(&s0, 0, sizeof s0);
    s0.theta0 = 0.7; s0.sequence = FS_SWVI_OPTIMIZED; s0.duration = 0.3;
    result r;

    /* ---- 1. amplitudes, eq. (5), at standstill on the true angle ---- */
    run(&s0, &r);
    const double I_d5 = U_H * TS / L_D;   /* eq. (5) at theta_err = 0, T_h = 4 Ts */
    printf("standstill: I_dh %.5f A (eq. (5): %.5f), I_qh %.2e A, error %.2e rad\n", r.I_dh, I_d5, r.I_qh, r.err_mean);
    FS_CHECK_REL(r.I_dh, I_d5, 0.02, 0, "I_dh within 2 % of eq. (5)");
    FS_CHECK(fabs(r.err_mean) < 1e-3 && r.err_max < 2e-3, "standstill: error %.2e, max %.2e", r.err_mean, r.err_max);
    FS_CHECK(fabs(r.s.k_norm - k_norm) < 1e-4 * k_norm, "K_norm = eq. (7)");

    /* ---- 2. lock from an initial error of 0.5 rad ---- */
    scen s = s0; s.pll_err0 = 0.5;
    run(&s, &r);
    FS_CHECK(fabs(r.err_mean) < 1e-3, "locks from 0.5 rad: error %.2e", r.err_mean);
    fs_swvi sw;
    fs_swvi_config c;

    /* ---- 3. optimized sequence: -1.5 w_e Ts at two speeds, eq. (18) ---- */
    for (int v = 0; v < 2; ++v) {
        s = s0; s.w_e = v == 0 ? 141.37 : 282.74;   /* 150 and 300 rpm, p = 9 */
        run(&s, &r);
        double want = -1.5 * s.w_e * TS;
        printf("optimized at w_e = %.1f: error %.5f rad (eq. (18): %.5f)\n", s.w_e, r.err_mean, want);
        FS_CHECK_REL(r.err_mean, want, 0.05, 0, "optimized: -1.5 w_e Ts");
        FS_CHECK_REL(r.s.w, s.w_e, 0.01, 0, "speed estimate");
    }

    /* ---- 4. conventional: lags by (L_Sigma / (4 L_dif) - 1.25) w_e Ts ---- */
    for (int v = 0; v < 2; ++v) {
        s = s0; s.w_e = v == 0 ? 141.37 : 282.74; s.sequence = FS_SWVI_CONVENTIONAL;
        run(&s, &r);
        double want = ((L_D + L_Q) / (4 * (L_Q - L_D)) - 1.25) * s.w_e * TS;
        printf("conventional at w_e = %.1f: error %.5f rad (common-mode leak: %.5f)\n", s.w_e, r.err_mean, want);
        FS_CHECK(r.err_mean > 0.0, "conventional lags");
        FS_CHECK_REL(r.err_mean, want, 0.10, 0, "conventional: the leak's lag");
    }

    /* ---- 5. cross-saturation: the HF axis at theta + delta, delta = -phi_dq / 2 ---- */
    s = s0; s.L_dq = -0.6e-3;
    /* eq. (21), theta_err = phi_dq / 2, with phi_dq = atan(2 L_dq / (L_q - L_d)):
     * eq. (20)'s L_dif is the half difference there (as in its ref. [26]),
     * not the L_q - L_d of eq. (3) */
    const double delta = -0.5 * atan2(2.0 * s.L_dq, L_Q - L_D);
    run(&s, &r);
    printf("L_dq = %.2g H: PLL error %.4f rad (eq. (21): %.4f)\n", s.L_dq, r.pll_err_mean, -delta);
    FS_CHECK_NEAR(r.pll_err_mean, -delta, 2e-3, "uncompensated: theta - theta_pll = phi_dq / 2");
    s.xcomp.n = 2; s.xcomp.i_q0 = -1.0f; s.xcomp.di_q = 2.0f;
    s.xcomp.delta[0] = s.xcomp.delta[1] = (float)delta;
    run(&s, &r);
    FS_CHECK_NEAR(r.err_mean, 0.0, 2e-3, "compensated by the table: no error");
    FS_CHECK_NEAR(r.s.delta, delta, 1e-6, "delta used");
    /* eq. (22) as a cubic (the error theta_r - theta_hat = -delta) */
    fs_xcomp_config p;
    memset(&p, 0, sizeof p);
    p.poly[0] = -0.018f; p.poly[1] = 0.025f; p.poly[3] = 0.0015f;
    for (int q = -6; q <= 6; ++q) {
        double iq = q, e22 = -0.0015 * iq * iq * iq - 0.025 * iq + 0.018;
        FS_CHECK_NEAR(fs_xcomp_eval(&p, (float)iq), -e22, 1e-6, "eq. (22)");
    }
    p.poly[3] = 1.0f;
    FS_CHECK_NEAR(fs_xcomp_eval(&p, 100.0f), 0.5 * PI, 1e-6, "cubic held within pi/2");
    FS_CHECK(fs_xcomp_eval(&p, NAN) == 0.0f, "NaN current: 0");

    /* ---- 6. carrier: the pattern and the half-length start ---- */
    c = r.s.cfg;
    c.xcomp.n = 0;
    fs_swvi_init(&sw, &c);
    const fs_ab zero = {0.0f, 0.0f};
    const float want_sign[9] = {0, -1, 1, 1, -1, -1, 1, 1, -1};   /* interval j = k + 1 */
    for (int k = 0; k < 9; ++k) {
        fs_swvi_step(&sw, zero);
        FS_CHECK_NEAR(sw.u.alpha, want_sign[k] * U_H, 1e-4, "carrier pattern");
        FS_CHECK(sw.ff_fresh == (k % 2 == 0), "zero crossings at the even samples");
    }

    /* carrier off: no voltage, the PLL stays where it is */
    c.carrier_off = true;
    fs_swvi_init(&sw, &c);
    fs_swvi_reset(&sw, 0.3f, 0.0f);
    const fs_ab i_any = {1.0f, -2.0f};
    for (int k = 0; k < 40; ++k) {
        fs_swvi_step(&sw, i_any);
        FS_CHECK(sw.u.alpha == 0.0f && sw.u.beta == 0.0f, "carrier off: no voltage");
    }
    FS_CHECK_NEAR(sw.theta, 0.3, 1e-6, "carrier off: the angle holds");
    FS_CHECK(sw.i_f.alpha == 1.0f && sw.ff_fresh == (40 % 2 == 1), "carrier off: the loops' timing kept");
    c.carrier_off = false;

    /* ---- 7. init refusals ---- */
    fs_swvi_config b;
#define REFUSE(field, value, status) \
    do { b = c; b.field = (value); FS_CHECK_EQ_INT(fs_swvi_init(&sw, &b), status, #field " = " #value); } while (0)
    REFUSE(Ts, 0.0f, FS_ERR_TS); REFUSE(Ts, NAN, FS_ERR_TS);
    REFUSE(delay, 2, FS_ERR_PARAM); REFUSE(delay, -1, FS_ERR_PARAM); REFUSE(delay, 0, FS_OK);
    REFUSE(u_h, 0.0f, FS_ERR_PARAM); REFUSE(u_h, INFINITY, FS_ERR_PARAM);
    REFUSE(sequence, 2, FS_ERR_PARAM);
    REFUSE(L_d, 0.0f, FS_ERR_LD); REFUSE(L_q, -1.0f, FS_ERR_LQ);
    REFUSE(L_q, (float)L_D, FS_ERR_SALIENCY);
    REFUSE(bandwidth, 0.0f, FS_ERR_BANDWIDTH); REFUSE(w_max, -1.0f, FS_ERR_LIMIT);
    REFUSE(xcomp.n, 1, FS_ERR_PARAM); REFUSE(xcomp.poly[2], NAN, FS_ERR_PARAM);
    FS_CHECK_EQ_INT(fs_swvi_init(NULL, &c), FS_ERR_NULL, "NULL");
    return fs_test_summary("test_swvi");
}
