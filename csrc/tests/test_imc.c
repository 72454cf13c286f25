/* fs-test-sources: control/fs_imc.c control/fs_transforms.c control/fs_svpwm.c
 *
 * fs_imc (zou2021 sec. 3 and 4.3). Every reference value is computed here in
 * double from the paper's equations, not taken from the implementation.
 *
 * Rectifier, over a 3600-point input-angle grid, depth angles alpha in
 * {0, pi/24, pi/12, pi/8, pi/6} plus random ones, V_im in {1e-3, 1, 325}:
 *  - the two shares are in [0, 1] and sum to 1 (T_max + T_mid = T_s); the
 *    rails are valid distinct phases with u_p >= u_n; the first interval is
 *    on the largest line voltage (eq. (2)), the second on the middle one
 *    (eq. (3)); v_pn is the share-weighted mean of the line voltages;
 *  - CASE 1: shares are eqs. (4)-(5); the period-mean input current (dc
 *    current 1) is parallel to u_in (unity power factor, 1e-4 rad);
 *    v_pn is eq. (6), 3 V_im / (2 cos theta_s), theta_s from the nearest
 *    phase peak; CASE 2: T_max = T_s (eq. (7)), v_pn = u_max - u_min (eq. (8));
 *  - CASE 2 exactly within alpha of a middle phase's zero crossing (eq. (11):
 *    sector 1 [pi/6 - alpha, pi/6), mirrored in the other sectors; one grid
 *    step of tolerance at the boundary);
 *  - sector k covers [(k-1) pi/6, k pi/6) (either neighbour exactly at a
 *    boundary).
 * Sector means: the midpoint-rule mean of v_pn over each of the twelve
 * sectors and over the whole input cycle equals eq. (12) (own double
 * implementation and fs_imc_vpn) within 0.5 % (and, tighter, 2e-4);
 * eq. (9) at alpha = 0, eq. (10) at alpha = pi/6; fs_imc_vpn is eq. (12)
 * and clamps alpha to [0, pi/6].
 * VTR: linear sqrt3/2; OM-I 27 (ln 3)^2 / (2 pi^2 sqrt3) (0.954 within 1e-3);
 * OM-II at pi/6 9 ln3 / pi^2 (about 1.002), in between eqs. (12), (20), (21);
 * fs_imc_region_of; fs_imc_alpha_for_vtr is 0 / pi/6 outside, round-trips
 * within 1e-4, agrees with an own inversion of eq. (12), and is monotonic.
 * Inverter stage: fs_svpwm with u_dc = v_pn of the rectifier: duties in
 * [0, 1], beyond the hexagon the realised vector keeps the reference's phase
 * (1e-4 rad), inside it equals the reference.
 * Depth controller: design status and gains (k_i = bw / G, k_p = 0.5 / G with
 * G from eq. (12), (20), (21)); errors for Ts <= 0, bw > 1/Ts, V_im <= 0;
 * weakening = false gives 0 and clears the integral; a constant positive
 * error rises as k_p e + n Ts k_i e and saturates at pi/6 exactly, never
 * above; a negative error from rest stays at 0; after long saturation a
 * negative error lowers alpha at once and reaches 0 in the number of steps
 * the gains give (no windup).
 * Degenerate input: u_in = 0 gives finite output, shares summing to 1,
 * v_pn = 0.
 */
#include <stdint.h>

#include "control/fs_imc.h"
#include "control/fs_svpwm.h"
#include "tests/fs_test.h"

#define PI FS_TEST_PI
#define SQRT3 1.7320508075688772
#define GRID 3600

/* ---- references in double ------------------------------------------- */

static void input_at(double V, double th, float u[3])
{
    u[0] = (float)(V * cos(th));
    u[1] = (float)(V * cos(th - 2.0 * PI / 3.0));
    u[2] = (float)(V * cos(th + 2.0 * PI / 3.0));
}

/* theta wrapped to [0, 2 pi) */
static double wrap_2pi(double th)
{
    th = fmod(th, 2.0 * PI);
    return th < 0.0 ? th + 2.0 * PI : th;
}

/* theta_s: the angle from the nearest peak of |u| (every pi/3), |.| <= pi/6 */
static double from_peak(double th)
{
    return th - PI / 3.0 * floor(th / (PI / 3.0) + 0.5);
}

/* eq. (12) over V_im */
static double ref_vpn(double a)
{
    return 9.0 / PI * (log(tan(PI / 3.0 - 0.5 * a)) + 2.0 / SQRT3 * sin(a));
}

/* eqs. (20)-(21): the VTR the over-modulated inverter reaches on V_pn */
static double ref_vtr(double a)
{
    return 3.0 * log(3.0) / PI * ref_vpn(a) / SQRT3;
}

/* eqs. (4)-(5): T_max / T_s in CASE 1, sector k (1..12), angle th */
static double ref_tmax(int k, double th)
{
    if (k % 2) return sin(th - (k - 2) * PI / 6.0) / cos(th - (k - 1) * PI / 6.0);
    return sin((k + 1) * PI / 6.0 - th) / cos(k * PI / 6.0 - th);
}

static double ang_diff(double a, double b)
{
    return fs_test_wrap(a - b);
}

static double angle_of(const double x[3])
{
    double al = (2.0 * x[0] - x[1] - x[2]) / 3.0, be = (x[1] - x[2]) / SQRT3;
    return atan2(be, al);
}

/* xorshift32: reproducible random numbers in [0, 1) */
static uint32_t rng_state = 2463534242u;
static double rnd(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 17;
    rng_state ^= rng_state << 5;
    return (double)rng_state / 4294967296.0;
}

/* ---- rectifier, one point ------------------------------------------- */

/* The structural checks that hold for any input: valid, distinct, ordered
 * rails, shares in [0, 1] summing to 1, v_pn the weighted line voltages. */
static void check_structure(const float u[3], const fs_imc_rect *r, const char *where)
{
    double sum = 0.0, vw = 0.0, scale = fabs(u[0]) + fabs(u[1]) + fabs(u[2]) + 1e-30;
    for (int k = 0; k < 2; ++k) {
        const fs_imc_interval *iv = &r->iv[k];
        FS_CHECK(iv->p >= 0 && iv->p <= 2 && iv->n >= 0 && iv->n <= 2 && iv->p != iv->n,
                 "%s: interval %d rails p = %d n = %d", where, k, iv->p, iv->n);
        if (!(iv->p >= 0 && iv->p <= 2 && iv->n >= 0 && iv->n <= 2)) return;
        FS_CHECK(u[iv->p] >= u[iv->n], "%s: interval %d: u_p = %g < u_n = %g", where, k, u[iv->p], u[iv->n]);
        FS_CHECK(iv->d >= 0.0f && iv->d <= 1.0f, "%s: interval %d share %.9g", where, k, iv->d);
        sum += iv->d;
        vw += iv->d * ((double)u[iv->p] - u[iv->n]);
    }
    FS_CHECK_NEAR(sum, 1.0, 1e-6, where);
    FS_CHECK(isfinite(r->v_pn), "%s: v_pn = %g", where, r->v_pn);
    FS_CHECK_NEAR(r->v_pn, vw, 1e-6 * scale, where);
    FS_CHECK(r->sector >= 1 && r->sector <= 12, "%s: sector %d", where, r->sector);
}

/* All point checks at input angle th, depth angle a, amplitude V; step is
 * the grid spacing (the tolerance of the CASE 2 window's boundary). Returns
 * v_pn / V. */
static double check_point(double V, double th, double a, double step)
{
    char where[96];
    snprintf(where, sizeof where, "V = %g th = %.9g alpha = %.9g", V, th, a);
    float u[3];
    input_at(V, th, u);
    fs_imc_rect r;
    fs_imc_rectifier(u, (float)a, &r);
    check_structure(u, &r, where);

    double ud[3] = {u[0], u[1], u[2]};
    double umax = fmax(ud[0], fmax(ud[1], ud[2])), umin = fmin(ud[0], fmin(ud[1], ud[2]));
    double umid = ud[0] + ud[1] + ud[2] - umax - umin;
    const double tol = 2e-6 * V;

    /* sector: [(k-1) pi/6, k pi/6), either neighbour right at a boundary */
    double thw = wrap_2pi(th);
    int k_ref = (int)floor(thw / (PI / 6.0)) + 1;
    if (k_ref > 12) k_ref = 12;
    double to_edge = thw - (k_ref - 1) * PI / 6.0;
    bool at_edge = to_edge < 1e-5 || PI / 6.0 - to_edge < 1e-5;
    if (at_edge) {
        int below = (to_edge < 1e-5) ? (k_ref == 1 ? 12 : k_ref - 1) : (k_ref == 12 ? 1 : k_ref + 1);
        FS_CHECK(r.sector == k_ref || r.sector == below, "%s: sector %d, expected %d or %d", where, r.sector, k_ref,
                 below);
    } else {
        FS_CHECK_EQ_INT(r.sector, k_ref, where);
    }

    /* CASE 2 within alpha of the middle phase's zero crossing (eq. (11)) */
    double ths = from_peak(thw);
    double to_crossing = PI / 6.0 - fabs(ths);
    if (fabs(to_crossing - a) > step) {
        bool want = to_crossing < a;
        FS_CHECK(r.case2 == want, "%s: case2 = %d, expected %d (%.6g rad from the zero crossing)", where, r.case2,
                 want, to_crossing);
    }

    /* the first interval on the largest line voltage, eq. (2); the second
     * on the middle one, eq. (3) */
    FS_CHECK_NEAR((double)u[r.iv[0].p] - u[r.iv[0].n], umax - umin, tol, "T_max on the largest line voltage");
    double dv_mid = fabs(umax) >= fabs(umin) ? umax - umid : umid - umin;
    if (!r.case2) FS_CHECK_NEAR((double)u[r.iv[1].p] - u[r.iv[1].n], dv_mid, tol, "T_mid on the middle line voltage");

    if (r.case2) {
        FS_CHECK(r.iv[0].d == 1.0f && r.iv[1].d == 0.0f, "%s: CASE 2 shares %g %g (eq. (7))", where, r.iv[0].d,
                 r.iv[1].d);
        FS_CHECK_NEAR(r.v_pn, V * SQRT3 * cos(fabs(ths) - PI / 6.0), 4e-6 * V, "CASE 2 v_pn (eq. (8), analytic)");
        FS_CHECK_NEAR(r.v_pn, umax - umin, tol, "CASE 2 v_pn = u_max - u_min");
    } else {
        /* eqs. (4)-(5), with the sector from the angle (continuous across
         * sector boundaries, so the edge ambiguity does not matter) */
        double tmax = ref_tmax(k_ref, thw);
        FS_CHECK_NEAR(r.iv[0].d, tmax, 2e-6, "CASE 1 T_max (eq. (4))");
        FS_CHECK_NEAR(r.iv[1].d, 1.0 - tmax, 2e-6, "CASE 1 T_mid (eq. (5))");
        /* eq. (6) */
        FS_CHECK_NEAR(r.v_pn, 1.5 * V / cos(ths), 4e-6 * V, "CASE 1 v_pn (eq. (6))");
        /* unity input power factor: the period-mean input current */
        double i[3] = {0.0, 0.0, 0.0};
        for (int j = 0; j < 2; ++j) {
            i[r.iv[j].p] += r.iv[j].d;
            i[r.iv[j].n] -= r.iv[j].d;
        }
        double da = ang_diff(angle_of(i), th);
        FS_CHECK(fabs(da) <= 1e-4, "%s: CASE 1 input current %.3g rad off u_in", where, da);
    }
    FS_CHECK_NEAR(fs_imc_amplitude(u), V, 2e-6 * V, "fs_imc_amplitude is V_im");
    return r.v_pn / V;
}

/* ---- tests ------------------------------------------------------------ */

static double alphas[8];
static int n_alphas = 0;

static void make_alphas(void)
{
    const double fixed[] = {0.0, PI / 24.0, PI / 12.0, PI / 8.0, PI / 6.0};
    for (int k = 0; k < 5; ++k) alphas[n_alphas++] = fixed[k];
    while (n_alphas < 8) alphas[n_alphas++] = rnd() * PI / 6.0;
}

static void test_rectifier_grid(void)
{
    const double amps[] = {1e-3, 1.0, 325.0};
    const double step = 2.0 * PI / GRID;
    for (int v = 0; v < 3; ++v)
        for (int ia = 0; ia < n_alphas; ++ia)
            for (int k = 0; k < GRID; ++k) check_point(amps[v], k * step, alphas[ia], step);
    /* random angles, including negative and beyond 2 pi */
    for (int k = 0; k < 2000; ++k) check_point(230.0 * SQRT3, (rnd() - 0.3) * 6.0 * PI, rnd() * PI / 6.0, 1e-6);
}

/* Sector 1 explicitly: CASE 2 exactly on [pi/6 - alpha, pi/6) (eq. (11)). */
static void test_case2_window_sector1(void)
{
    const int n = 3000;
    const double h = PI / 6.0 / n;
    for (int ia = 0; ia < n_alphas; ++ia) {
        double a = alphas[ia];
        int wrong = 0, first_wrong = -1;
        for (int k = 0; k < n; ++k) {
            double th = k * h;
            float u[3];
            input_at(1.0, th, u);
            fs_imc_rect r;
            fs_imc_rectifier(u, (float)a, &r);
            bool want = th >= PI / 6.0 - a;
            if (r.case2 != want && fabs(th - (PI / 6.0 - a)) > h) {
                if (first_wrong < 0) first_wrong = k;
                ++wrong;
            }
        }
        FS_CHECK(wrong == 0, "alpha = %.6g: %d grid points of sector 1 on the wrong CASE (first at th = %.6g)", a,
                 wrong, first_wrong * h);
    }
}

/* Midpoint mean of v_pn / V_im over [t0, t1) with n points. */
static double mean_vpn(double t0, double t1, int n, double a)
{
    double h = (t1 - t0) / n, s = 0.0;
    for (int k = 0; k < n; ++k) {
        float u[3];
        input_at(1.0, t0 + (k + 0.5) * h, u);
        fs_imc_rect r;
        fs_imc_rectifier(u, (float)a, &r);
        s += r.v_pn;
    }
    return s / n;
}

static void test_sector_means(void)
{
    FS_CHECK_NEAR(ref_vpn(0.0), 9.0 * log(3.0) / (2.0 * PI), 1e-12, "own eq. (12) at 0 is eq. (9)");
    FS_CHECK_NEAR(ref_vpn(PI / 6.0), 3.0 * SQRT3 / PI, 1e-12, "own eq. (12) at pi/6 is eq. (10)");
    for (int ia = 0; ia < n_alphas; ++ia) {
        double a = alphas[ia], ref = ref_vpn(a), lib = fs_imc_vpn((float)a);
        FS_CHECK_REL(lib, ref, 1e-5, 0.0, "fs_imc_vpn is eq. (12)");
        for (int s = 0; s < 12; ++s) {
            double m = mean_vpn(s * PI / 6.0, (s + 1) * PI / 6.0, 3000, a);
            char what[64];
            snprintf(what, sizeof what, "sector %d mean, alpha = %.6g", s + 1, a);
            FS_CHECK_REL(m, ref, 5e-3, 0.0, what);
            FS_CHECK_REL(m, lib, 5e-3, 0.0, what);
            FS_CHECK_REL(m, ref, 2e-4, 0.0, what);
        }
        double m = mean_vpn(0.0, 2.0 * PI, 12 * 3000, a);
        FS_CHECK_REL(m, ref, 5e-3, 0.0, "full-cycle mean vs eq. (12)");
        FS_CHECK_REL(m, lib, 5e-3, 0.0, "full-cycle mean vs fs_imc_vpn");
        FS_CHECK_REL(m, ref, 2e-4, 0.0, "full-cycle mean vs eq. (12), tight");
        if (a == 0.0) FS_CHECK_REL(m, 9.0 * log(3.0) / (2.0 * PI), 5e-3, 0.0, "eq. (9)");
        if (a == PI / 6.0) FS_CHECK_REL(m, 3.0 * SQRT3 / PI, 5e-3, 0.0, "eq. (10)");
    }
    /* a fine sweep of fs_imc_vpn, and its clamping */
    double prev = -1.0;
    for (int k = 0; k <= 200; ++k) {
        double a = k * (PI / 6.0) / 200.0, v = fs_imc_vpn((float)a);
        FS_CHECK_REL(v, ref_vpn(a), 1e-5, 0.0, "fs_imc_vpn sweep");
        FS_CHECK(v >= prev, "fs_imc_vpn not monotonic at alpha = %g", a);
        prev = v;
    }
    FS_CHECK_REL(fs_imc_vpn(-0.3f), ref_vpn(0.0), 1e-6, 0.0, "fs_imc_vpn clamps below 0");
    FS_CHECK_REL(fs_imc_vpn(1.2f), ref_vpn(PI / 6.0), 1e-6, 0.0, "fs_imc_vpn clamps above pi/6");
}

/* Own inversion of eqs. (12), (20), (21): alpha for VTR q, by bisection in double. */
static double ref_alpha_for(double q)
{
    double lo = 0.0, hi = PI / 6.0;
    for (int k = 0; k < 80; ++k) {
        double mid = 0.5 * (lo + hi);
        if (ref_vtr(mid) < q) lo = mid; else hi = mid;
    }
    return 0.5 * (lo + hi);
}

static void test_vtr(void)
{
    const double om1 = 27.0 * log(3.0) * log(3.0) / (2.0 * PI * PI * SQRT3);
    const double om2 = 9.0 * log(3.0) / (PI * PI);
    FS_CHECK_NEAR(fs_imc_vtr_max(FS_IMC_LINEAR, 0.0f), SQRT3 / 2.0, 1e-6, "linear: sqrt3/2");
    FS_CHECK_NEAR(fs_imc_vtr_max(FS_IMC_LINEAR, 0.3f), SQRT3 / 2.0, 1e-6, "linear ignores alpha");
    FS_CHECK_NEAR(fs_imc_vtr_max(FS_IMC_OM1, 0.0f), om1, 1e-5, "OM-I: 27 ln3^2 / (2 pi^2 sqrt3)");
    FS_CHECK_NEAR(fs_imc_vtr_max(FS_IMC_OM1, 0.0f), 0.954, 1e-3, "OM-I: 0.954 (paper)");
    FS_CHECK_NEAR(fs_imc_vtr_max(FS_IMC_OM1, 0.4f), om1, 1e-5, "OM-I: CASE 1 alone, whatever alpha");
    FS_CHECK_NEAR(fs_imc_vtr_max(FS_IMC_OM2, (float)(PI / 6.0)), om2, 1e-5, "OM-II at pi/6: 9 ln3 / pi^2");
    FS_CHECK_NEAR(fs_imc_vtr_max(FS_IMC_OM2, (float)(PI / 6.0)), 1.002, 1e-3, "OM-II about 1.002");
    FS_CHECK_NEAR(fs_imc_vtr_max(FS_IMC_OM2, 0.0f), om1, 1e-5, "OM-II at 0 equals OM-I");
    for (int ia = 0; ia < n_alphas; ++ia)
        FS_CHECK_NEAR(fs_imc_vtr_max(FS_IMC_OM2, (float)alphas[ia]), ref_vtr(alphas[ia]), 1e-5, "OM-II vs own eqs");

    FS_CHECK_EQ_INT(fs_imc_region_of(0.5f), FS_IMC_LINEAR, "q = 0.5");
    FS_CHECK_EQ_INT(fs_imc_region_of(0.9f), FS_IMC_OM1, "q = 0.9");
    FS_CHECK_EQ_INT(fs_imc_region_of(0.98f), FS_IMC_OM2, "q = 0.98");
    FS_CHECK_EQ_INT(fs_imc_region_of(0.0f), FS_IMC_LINEAR, "q = 0");
    FS_CHECK_EQ_INT(fs_imc_region_of(0.86f), FS_IMC_LINEAR, "q = 0.86");
    FS_CHECK_EQ_INT(fs_imc_region_of(0.87f), FS_IMC_OM1, "q = 0.87");
    FS_CHECK_EQ_INT(fs_imc_region_of(0.95f), FS_IMC_OM1, "q = 0.95");
    FS_CHECK_EQ_INT(fs_imc_region_of(0.96f), FS_IMC_OM2, "q = 0.96");
    FS_CHECK_EQ_INT(fs_imc_region_of(1.5f), FS_IMC_OM2, "q = 1.5");

    const float qs_low[] = {0.0f, 0.5f, 0.866f, 0.9f, 0.95f, (float)(om1 - 1e-4)};
    for (int k = 0; k < 6; ++k)
        FS_CHECK(fs_imc_alpha_for_vtr(qs_low[k]) == 0.0f, "alpha_for_vtr(%g) = %g, expected 0", qs_low[k],
                 fs_imc_alpha_for_vtr(qs_low[k]));
    const float qs_high[] = {(float)(om2 + 1e-4), 1.01f, 1.2f, 5.0f};
    for (int k = 0; k < 4; ++k)
        FS_CHECK_NEAR(fs_imc_alpha_for_vtr(qs_high[k]), PI / 6.0, 1e-6, "alpha_for_vtr above OM-II: pi/6");

    double prev = 0.0;
    for (int k = 1; k < 400; ++k) {
        double q = om1 + (om2 - om1) * k / 400.0;
        double a = fs_imc_alpha_for_vtr((float)q);
        FS_CHECK(a >= 0.0 && a <= PI / 6.0 + 1e-6, "alpha_for_vtr(%g) = %g out of [0, pi/6]", q, a);
        FS_CHECK_NEAR(fs_imc_vtr_max(FS_IMC_OM2, (float)a), q, 1e-4, "round trip vtr_max(alpha_for_vtr(q))");
        FS_CHECK_NEAR(a, ref_alpha_for(q), 1e-3, "alpha_for_vtr vs own inversion of eq. (12)");
        FS_CHECK(a >= prev, "alpha_for_vtr not monotonic at q = %.7g: %.9g after %.9g", q, a, prev);
        prev = a;
    }
}

/* The inverter stage on the rectifier's v_pn (eqs. (13)-(16) via fs_svpwm). */
static void test_inverter(void)
{
    for (int k = 0; k < 400; ++k) {
        double V = 100.0 + 400.0 * rnd(), th_in = 2.0 * PI * rnd(), a = PI / 6.0 * rnd();
        float u[3];
        input_at(V, th_in, u);
        fs_imc_rect r;
        fs_imc_rectifier(u, (float)a, &r);
        float u_dc = r.v_pn;
        /* half the cases beyond the hexagon (> 2/3 u_dc), half inside its circle */
        bool beyond = k % 2 == 0;
        double mag = beyond ? (2.0 / 3.0) * u_dc * (1.05 + 2.0 * rnd()) : u_dc / SQRT3 * 0.98 * rnd();
        double th = 2.0 * PI * rnd();
        fs_ab ref = {(float)(mag * cos(th)), (float)(mag * sin(th))};
        float duty[3] = {-1.0f, -1.0f, -1.0f};
        fs_ab real;
        bool over = fs_svpwm(ref, u_dc, duty, &real);
        for (int j = 0; j < 3; ++j)
            FS_CHECK(duty[j] >= 0.0f && duty[j] <= 1.0f, "inverter: duty[%d] = %g (u_dc %g)", j, duty[j], u_dc);
        fs_ab out = fs_svpwm_voltage(duty, u_dc);
        if (beyond) {
            FS_CHECK(over, "inverter: |ref| = %g beyond 2/3 u_dc = %g not over-modulation", mag, 2.0 / 3.0 * u_dc);
            double da = ang_diff(atan2(out.beta, out.alpha), atan2(ref.beta, ref.alpha));
            FS_CHECK(fabs(da) <= 1e-4, "inverter: realised vector %.3g rad off the reference", da);
            FS_CHECK(hypot(out.alpha, out.beta) <= 2.0 / 3.0 * u_dc * (1.0 + 1e-5), "inverter: beyond the hexagon");
        } else {
            FS_CHECK_NEAR(out.alpha, ref.alpha, 1e-4 * u_dc, "inverter linear: alpha");
            FS_CHECK_NEAR(out.beta, ref.beta, 1e-4 * u_dc, "inverter linear: beta");
        }
    }
}

/* ---- depth controller ---------------------------------------------------- */

static const double TS = 1e-4, I_LIM = 10.0, VIM = 325.0, WE = 2.0 * PI * 300.0, LS = 1e-3, BW = 200.0;

static fs_imc_depth_config designed(void)
{
    fs_imc_depth_config c;
    fs_status s = fs_imc_depth_design(&c, (float)TS, (float)I_LIM, (float)VIM, (float)WE, (float)LS, (float)BW);
    FS_CHECK(s == FS_OK, "depth design: status %d", (int)s);
    return c;
}

static void test_depth_design(void)
{
    fs_imc_depth_config c = designed();
    FS_CHECK(c.k_p > 0.0f && c.k_i > 0.0f, "gains k_p = %g k_i = %g", c.k_p, c.k_i);
    FS_CHECK_NEAR(c.Ts, TS, 1e-10, "Ts stored");
    FS_CHECK_NEAR(c.i_lim, I_LIM, 1e-6, "i_lim stored");
    /* G: V_im (q(pi/6) - q(0)) / (w_e_max L) over pi/6 rad */
    double G = VIM * (ref_vtr(PI / 6.0) - ref_vtr(0.0)) / (WE * LS) / (PI / 6.0);
    FS_CHECK_REL(c.k_i, BW / G, 1e-4, 0.0, "k_i = bw / G");
    FS_CHECK_REL(c.k_p, 0.5 / G, 1e-4, 0.0, "k_p = 0.5 / G");

    fs_imc_depth_config d;
    FS_CHECK(fs_imc_depth_design(&d, 0.0f, 10.0f, 325.0f, 1885.0f, 1e-3f, 200.0f) != FS_OK, "Ts = 0");
    FS_CHECK(fs_imc_depth_design(&d, -1e-4f, 10.0f, 325.0f, 1885.0f, 1e-3f, 200.0f) != FS_OK, "Ts < 0");
    FS_CHECK(fs_imc_depth_design(&d, 1e-4f, 10.0f, 325.0f, 1885.0f, 1e-3f, 1.5e4f) != FS_OK, "bw above 1/Ts");
    FS_CHECK(fs_imc_depth_design(&d, 1e-4f, 10.0f, 0.0f, 1885.0f, 1e-3f, 200.0f) != FS_OK, "V_im = 0");
    FS_CHECK(fs_imc_depth_design(&d, 1e-4f, 10.0f, -325.0f, 1885.0f, 1e-3f, 200.0f) != FS_OK, "V_im < 0");
    FS_CHECK(fs_imc_depth_design(NULL, 1e-4f, 10.0f, 325.0f, 1885.0f, 1e-3f, 200.0f) != FS_OK, "null config");
    FS_CHECK(fs_imc_depth_design(&d, 1e-4f, 10.0f, 325.0f, 1885.0f, 1e-3f, 9e3f) == FS_OK, "bw below 1/Ts");
}

static void test_depth_step(void)
{
    const double amax = PI / 6.0, one_ulp = 1.2e-7;
    fs_imc_depth_config c = designed();
    fs_imc_depth dc;
    FS_CHECK(fs_imc_depth_init(&dc, &c) == FS_OK, "depth init");
    FS_CHECK(fs_imc_depth_init(NULL, &c) != FS_OK, "depth init: null");
    const double kp = c.k_p, ki_ts = (double)c.k_i * c.Ts;

    /* not weakening: 0 and nothing integrated */
    for (int k = 0; k < 50; ++k) {
        float a = fs_imc_depth_step(&dc, (float)(I_LIM + 5.0), false);
        FS_CHECK(a == 0.0f && dc.integ == 0.0f, "not weakening: alpha %g integ %g", a, dc.integ);
    }

    /* a constant positive error: k_p e + n Ts k_i e, up to pi/6 exactly */
    const double e = 1.0;
    double n_sat = (amax - kp * e) / (ki_ts * e);   /* steps to saturate */
    FS_CHECK(n_sat > 20.0 && n_sat < 5000.0, "test setup: %g steps to saturate", n_sat);
    int n_limit = (int)ceil(n_sat) + 2;
    double prev = 0.0;
    int reached = -1;
    for (int n = 1; n <= 3 * n_limit; ++n) {
        double a = fs_imc_depth_step(&dc, (float)(I_LIM + e), true);
        FS_CHECK(a <= amax + one_ulp, "step %d: alpha %.9g above pi/6", n, a);
        FS_CHECK(a >= prev, "step %d: alpha %.9g fell from %.9g under a positive error", n, a, prev);
        if (n < n_sat - 1.0) FS_CHECK_REL(a, kp * e + n * ki_ts * e, 1e-4, 1e-6, "PI ramp");
        if (reached < 0 && a >= amax - one_ulp) reached = n;
        prev = a;
    }
    FS_CHECK(reached >= (int)floor(n_sat) - 1 && reached <= n_limit, "saturated after %d steps, expected about %g",
             reached, n_sat);
    FS_CHECK_NEAR(prev, amax, one_ulp, "saturates at pi/6 exactly");
    /* a big error for long: still pi/6, and the integral stays within [0, pi/6] */
    for (int n = 0; n < 20000; ++n) {
        double a = fs_imc_depth_step(&dc, (float)(I_LIM + 1000.0), true);
        FS_CHECK(a <= amax + one_ulp, "huge error: alpha %.9g above pi/6", a);
    }
    FS_CHECK(dc.integ <= amax + one_ulp, "integral %.9g wound up beyond pi/6", dc.integ);

    /* no windup: a negative error brings it down at once and to 0 in the
     * steps the gains give */
    const double e2 = -2.0;
    double a1 = fs_imc_depth_step(&dc, (float)(I_LIM + e2), true);
    FS_CHECK(a1 < amax - 1e-6, "negative error after saturation: alpha %.9g did not fall at once", a1);
    FS_CHECK_NEAR(a1, amax + (kp + ki_ts) * e2, 1e-5, "first step down: pi/6 - (k_p + Ts k_i) |e|");
    double n_zero = (amax + kp * e2) / (ki_ts * -e2);   /* integral steps until k_p e + integ <= 0 */
    int n_down = 1;
    double a = a1;
    while (a > 0.0 && n_down < 100000) {
        a = fs_imc_depth_step(&dc, (float)(I_LIM + e2), true);
        FS_CHECK(a >= 0.0, "alpha %.9g below 0", a);
        ++n_down;
    }
    FS_CHECK(n_down <= (int)ceil(n_zero) + 1 && n_down >= (int)floor(n_zero) - 1,
             "down to 0 in %d steps, the gains give %g", n_down, n_zero);

    /* a negative error from rest stays at 0 */
    fs_imc_depth_reset(&dc);
    for (int n = 0; n < 1000; ++n) {
        double an = fs_imc_depth_step(&dc, (float)(I_LIM - 3.0), true);
        FS_CHECK(an == 0.0, "negative error from rest: alpha %.9g", an);
    }
    FS_CHECK(dc.integ == 0.0f, "negative error from rest: integral %g (not clamped at 0)", dc.integ);

    /* weakening = false clears the integral: after it, the ramp restarts */
    for (int n = 0; n < 3 * n_limit; ++n) fs_imc_depth_step(&dc, (float)(I_LIM + e), true);
    FS_CHECK(fs_imc_depth_step(&dc, (float)(I_LIM + e), false) == 0.0f, "gate: output 0");
    FS_CHECK(dc.integ == 0.0f && dc.alpha == 0.0f, "gate: integral %g alpha %g not cleared", dc.integ, dc.alpha);
    FS_CHECK_REL(fs_imc_depth_step(&dc, (float)(I_LIM + e), true), kp * e + ki_ts * e, 1e-4, 1e-7,
                 "after the gate the ramp restarts from zero");
    /* a non-finite current reference gives 0 */
    FS_CHECK(fs_imc_depth_step(&dc, NAN, true) == 0.0f, "NaN i_ref: 0");
}

/* ---- degenerate input --------------------------------------------------- */

static void test_degenerate(void)
{
    const float zero[3] = {0.0f, 0.0f, 0.0f};
    for (int ia = 0; ia < n_alphas; ++ia) {
        fs_imc_rect r;
        fs_imc_rectifier(zero, (float)alphas[ia], &r);
        check_structure(zero, &r, "zero input");
        FS_CHECK(r.v_pn == 0.0f, "zero input: v_pn = %g", r.v_pn);
        FS_CHECK(isfinite(r.iv[0].d) && isfinite(r.iv[1].d), "zero input: shares finite");
    }
    FS_CHECK(fs_imc_amplitude(zero) == 0.0f, "zero input: amplitude");
}

int main(void)
{
    make_alphas();
    test_rectifier_grid();
    test_case2_window_sector1();
    test_sector_means();
    test_vtr();
    test_inverter();
    test_depth_design();
    test_depth_step();
    test_degenerate();
    return fs_test_summary("test_imc");
}
