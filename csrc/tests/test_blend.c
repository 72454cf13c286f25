/* fs-test-sources: control/fs_blend.c control/fs_motion_obs.c control/fs_status.c
 *
 * fs_blend (yang2022 eqs. (27)-(28), Fig. 6): init validation; the weight
 * at and around the band edges, linear inside, even in the speed; the blend
 * on the circle (two angles either side of +-pi blend to +-pi, not 0; equal
 * angles blend to themselves; the result on the shorter arc); a speed
 * profile 0 -> +400 -> -400 el. rad/s through the band (10 % - 20 % of the
 * paper's rated speed) with the SMO angle a constant 0.3 rad off the HFI
 * angle: the weight moves continuously 0 -> 1 -> 0 -> 1, the filtered
 * angle moves from one source to the other without a jump, also where the
 * sources straddle +-pi; the SMO angle is not read at standstill.
 */
#include "control/fs_blend.h"
#include "control/fs_math.h"
#include "tests/fs_test.h"

/* Table 1 of the paper: J = 1.87 g m^2, p = 5, rated 2000 rpm = 1047 el. rad/s */
static const float J0 = 1.87e-3f;
static const int P0 = 5;
static const float W_RATED = 2000.0f * 2.0f * 3.14159265f / 60.0f * 5.0f;

static fs_blend_config cfg0(void)
{
    fs_blend_config c;
    c.w_lower = 0.1f * W_RATED;  /* 104.7 el. rad/s */
    c.w_upper = 0.2f * W_RATED;  /* 209.4 */
    c.obs.Ts = 1e-4f;
    c.obs.J = J0;
    c.obs.B = 0.0f;
    c.obs.pole_pairs = P0;
    c.obs.bandwidth = 200.0f;
    return c;
}

static void check_init(void)
{
    fs_blend b;
    fs_blend_config c = cfg0(), bad;
    FS_CHECK_EQ_INT(fs_blend_init(&b, &c), FS_OK, "init");
    FS_CHECK(b.theta_hat == 0.0f && b.w_hat == 0.0f && b.g_w == 0.0f, "init state");
    FS_CHECK_EQ_INT(fs_blend_init(NULL, &c), FS_ERR_NULL, "null blend");
    FS_CHECK_EQ_INT(fs_blend_init(&b, NULL), FS_ERR_NULL, "null cfg");
    bad = c; bad.w_lower = -1.0f;
    FS_CHECK_EQ_INT(fs_blend_init(&b, &bad), FS_ERR_LIMIT, "w_lower < 0");
    bad = c; bad.w_lower = NAN;
    FS_CHECK_EQ_INT(fs_blend_init(&b, &bad), FS_ERR_LIMIT, "w_lower NaN");
    bad = c; bad.w_upper = bad.w_lower;
    FS_CHECK_EQ_INT(fs_blend_init(&b, &bad), FS_ERR_LIMIT, "w_upper = w_lower");
    bad = c; bad.w_upper = 0.5f * bad.w_lower;
    FS_CHECK_EQ_INT(fs_blend_init(&b, &bad), FS_ERR_LIMIT, "w_upper < w_lower");
    bad = c; bad.w_upper = NAN;
    FS_CHECK_EQ_INT(fs_blend_init(&b, &bad), FS_ERR_LIMIT, "w_upper NaN");
    bad = c; bad.w_upper = INFINITY;
    FS_CHECK_EQ_INT(fs_blend_init(&b, &bad), FS_ERR_LIMIT, "w_upper infinite");
    bad = c; bad.w_lower = 0.0f;
    FS_CHECK_EQ_INT(fs_blend_init(&b, &bad), FS_OK, "w_lower = 0 is allowed");
    /* the observer's configuration is checked too */
    bad = c; bad.obs.Ts = 0.0f;
    FS_CHECK_EQ_INT(fs_blend_init(&b, &bad), FS_ERR_TS, "obs.Ts = 0");
    bad = c; bad.obs.J = -1.0f;
    FS_CHECK_EQ_INT(fs_blend_init(&b, &bad), FS_ERR_J, "obs.J < 0");
    bad = c; bad.obs.pole_pairs = 0;
    FS_CHECK_EQ_INT(fs_blend_init(&b, &bad), FS_ERR_POLE_PAIRS, "obs.pole_pairs = 0");
    bad = c; bad.obs.bandwidth = 0.0f;
    FS_CHECK_EQ_INT(fs_blend_init(&b, &bad), FS_ERR_BANDWIDTH, "obs.bandwidth = 0");
    bad = c; bad.obs.B = -1.0f;
    FS_CHECK_EQ_INT(fs_blend_init(&b, &bad), FS_ERR_PARAM, "obs.B < 0");

    /* reset: angle wrapped, speed, and the weight that speed gives */
    fs_blend_init(&b, &c);
    fs_blend_reset(&b, -4.0f, -0.15f * W_RATED);
    FS_CHECK_NEAR(b.theta_hat, -4.0 + 2.0 * FS_TEST_PI, 1e-6, "reset wraps");
    FS_CHECK_NEAR(b.w_hat, -0.15 * W_RATED, 1e-3, "reset speed");
    FS_CHECK_NEAR(b.g_w, 0.5, 1e-5, "reset weight at mid-band speed");
}

/* eq. (28) */
static void check_weight(void)
{
    const float lo = 100.0f, hi = 200.0f;
    FS_CHECK(fs_blend_weight(0.0f, lo, hi) == 0.0f, "g(0) = 0");
    FS_CHECK(fs_blend_weight(lo, lo, hi) == 0.0f, "g(w_lower) = 0");
    FS_CHECK(fs_blend_weight(hi, lo, hi) == 1.0f, "g(w_upper) = 1");
    FS_CHECK(fs_blend_weight(nextafterf(lo, 0.0f), lo, hi) == 0.0f, "just below w_lower");
    FS_CHECK(fs_blend_weight(nextafterf(hi, 1e9f), lo, hi) == 1.0f, "just above w_upper");
    FS_CHECK(fs_blend_weight(1e6f, lo, hi) == 1.0f, "far above");
    /* continuous at the edges: no step at either end of the band */
    FS_CHECK_NEAR(fs_blend_weight(lo + 0.01f, lo, hi), 1e-4, 2e-6, "just inside w_lower");
    FS_CHECK_NEAR(fs_blend_weight(hi - 0.01f, lo, hi), 1.0 - 1e-4, 2e-6, "just inside w_upper");
    FS_CHECK_NEAR(fs_blend_weight(125.0f, lo, hi), 0.25, 1e-7, "a quarter in");
    FS_CHECK_NEAR(fs_blend_weight(150.0f, lo, hi), 0.5, 1e-7, "mid-band");
    FS_CHECK_NEAR(fs_blend_weight(175.0f, lo, hi), 0.75, 1e-7, "three quarters in");
    /* even in the speed, monotone in |w|, within [0, 1] */
    float prev = 0.0f;
    for (int i = 0; i <= 3000; ++i) {
        const float w = 0.1f * (float)i;
        const float g = fs_blend_weight(w, lo, hi), gn = fs_blend_weight(-w, lo, hi);
        FS_CHECK(g == gn, "g(%g) = %.9g but g(-%g) = %.9g", (double)w, (double)g, (double)w, (double)gn);
        FS_CHECK(g >= prev && g >= 0.0f && g <= 1.0f, "g(%g) = %.9g after %.9g", (double)w, (double)g, (double)prev);
        FS_CHECK(g - prev <= 0.1f / (hi - lo) + 1e-6f, "step of g at %g: %.3g", (double)w, (double)(g - prev));
        prev = g;
    }
    /* w_lower = 0: the band starts at standstill */
    FS_CHECK(fs_blend_weight(0.0f, 0.0f, 10.0f) == 0.0f, "g(0) with w_lower = 0");
    FS_CHECK_NEAR(fs_blend_weight(-5.0f, 0.0f, 10.0f), 0.5, 1e-7, "g(-5) with w_lower = 0");
}

/* eq. (27) on the circle */
static void check_angle(void)
{
    const float pi = FS_PI;
    /* either side of +-pi, half and half: +-pi, not 0 (the naive
     * 0.5 (pi - 0.01) + 0.5 (-pi + 0.01) is 0) */
    float t = fs_blend_angle(pi - 0.01f, -pi + 0.01f, 0.5f);
    FS_CHECK(t > -pi && t <= pi, "result %.9g outside (-pi, pi]", (double)t);
    FS_CHECK_NEAR(fabs(fs_test_wrap((double)t - FS_TEST_PI)), 0.0, 1e-6, "pi - 0.01 and -pi + 0.01 blend to pi");
    t = fs_blend_angle(-pi + 0.01f, pi - 0.01f, 0.5f);
    FS_CHECK_NEAR(fabs(fs_test_wrap((double)t - FS_TEST_PI)), 0.0, 1e-6, "and the other way round");
    /* a quarter of the way from HFI = -pi + 0.01 across the wrap */
    t = fs_blend_angle(pi - 0.01f, -pi + 0.01f, 0.25f);
    FS_CHECK_NEAR(t, -FS_TEST_PI + 0.005, 1e-6, "a quarter of the arc across the wrap");
    t = fs_blend_angle(pi - 0.01f, -pi + 0.01f, 0.75f);
    FS_CHECK_NEAR(t, FS_TEST_PI - 0.005, 1e-6, "three quarters of the arc across the wrap");
    /* equal angles: that angle, for any weight */
    const float angles[] = {0.0f, 1.0f, -2.5f, pi, -pi + 1e-6f, nextafterf(pi, 0.0f), 3.0f};
    const float weights[] = {0.0f, 1e-7f, 0.1f, 0.5f, 0.9f, 0.9999999f, 1.0f};
    for (int i = 0; i < 7; ++i) {
        for (int j = 0; j < 7; ++j) {
            t = fs_blend_angle(angles[i], angles[i], weights[j]);
            FS_CHECK(t == angles[i], "blend of %.9g with itself at g = %g gives %.9g",
                     (double)angles[i], (double)weights[j], (double)t);
        }
    }
    /* the ends return the sources, the other one unread */
    FS_CHECK(fs_blend_angle(1.0f, -2.0f, 0.0f) == -2.0f, "g = 0: HFI");
    FS_CHECK(fs_blend_angle(1.0f, -2.0f, 1.0f) == 1.0f, "g = 1: SMO");
    FS_CHECK(fs_blend_angle(NAN, -2.0f, 0.0f) == -2.0f, "g = 0 does not read the SMO angle");
    FS_CHECK(fs_blend_angle(1.0f, NAN, 1.0f) == 1.0f, "g = 1 does not read the HFI angle");
    FS_CHECK(fs_blend_angle(7.0f, -2.0f, 1.0f) == fs_wrap_pi(7.0f), "the ends are wrapped");
    /* any pair: the result is at the fraction g of the shorter arc */
    double worst = 0.0;
    for (int i = 0; i < 64; ++i) {
        for (int j = 0; j < 64; ++j) {
            const double a = -FS_TEST_PI + (i + 0.5) * (2.0 * FS_TEST_PI / 64.0);
            const double h = -FS_TEST_PI + (j + 0.25) * (2.0 * FS_TEST_PI / 64.0);
            for (int k = 0; k <= 4; ++k) {
                const double g = 0.25 * k;
                t = fs_blend_angle((float)a, (float)h, (float)g);
                FS_CHECK(t > -pi && t <= pi, "result %.9g outside (-pi, pi]", (double)t);
                const double d = fabs(fs_test_wrap(t - (h + g * fs_test_wrap(a - h))));
                if (d > worst) worst = d;
            }
        }
    }
    FS_CHECK(worst < 1e-6, "blend off the shorter arc by %.3g", worst);
}

/* Speed profile w(t) piecewise linear, theta_HFI = theta, theta_SMO =
 * theta + delta; T_ff = J alpha / p. Records the weight, the step-to-step
 * motion of the filtered and blended angles beyond the true motion. */
typedef struct {
    double max_dg;          /* largest |g[k] - g[k-1]| */
    double max_dth_hat;     /* largest |wrap(theta_hat[k] - theta_hat[k-1]) - true motion| */
    double max_dth_blnd;    /* same for theta_blnd */
    int g_reversals;        /* times g moved against the direction |w| moved */
} run_stats;

static double profile_w(double t)
{
    /* 0 (0.05 s) -> +400 at 1000 rad/s^2 (0.4 s), hold 0.15 s,
     * -> -400 at 2000 rad/s^2 (0.4 s), hold 0.15 s; total 1.15 s */
    static const double T[] = {0.0, 0.05, 0.45, 0.60, 1.00, 1.15};
    static const double W[] = {0.0, 0.0, 400.0, 400.0, -400.0, -400.0};
    for (int i = 0; i < 5; ++i) {
        if (t < T[i + 1]) return W[i] + (W[i + 1] - W[i]) / (T[i + 1] - T[i]) * (t - T[i]);
    }
    return W[5];
}

static void check_transition(float band_frac_hi, int expect_smooth)
{
    fs_blend b;
    fs_blend_config c = cfg0();
    c.w_upper = band_frac_hi * W_RATED;
    FS_CHECK_EQ_INT(fs_blend_init(&b, &c), FS_OK, "init");
    const double Ts = c.obs.Ts, delta = 0.3;
    const int n = (int)(1.15 / Ts);
    double theta = 0.4;  /* true electrical angle, unwrapped */
    fs_blend_reset(&b, (float)theta, 0.0f);
    run_stats s = {0.0, 0.0, 0.0, 0};
    double prev_hat = b.theta_hat, prev_blnd = b.theta_blnd, prev_g = b.g_w, prev_w = 0.0;
    double err_hfi_low = 0.0, err_smo_end = 0.0, err_smo_hold = 0.0, err_hfi_zero = 0.0;
    double g_at_hold = 0.0, g_min_mid = 1.0;
    int straddles = 0, wraps = 0;
    for (int k = 1; k <= n; ++k) {
        const double t0 = (k - 1) * Ts, t = k * Ts;
        const double w0 = profile_w(t0), w1 = profile_w(t);
        const double dtheta = 0.5 * (w0 + w1) * Ts;  /* exact for piecewise-linear speed */
        theta += dtheta;
        const double th_hfi = fs_test_wrap(theta), th_smo = fs_test_wrap(theta + delta);
        if ((th_hfi > 0.0) != (th_smo > 0.0) && fabs(th_hfi) > 2.0) ++straddles;
        const double T_ff = (w1 - w0) / Ts * J0 / P0;  /* mean torque over the period */
        fs_blend_step(&b, (float)th_smo, (float)th_hfi, (float)T_ff);
        if (fabsf(b.theta_hat - (float)prev_hat) > FS_PI) ++wraps;

        const double dg = b.g_w - prev_g;
        if (fabs(dg) > s.max_dg) s.max_dg = fabs(dg);
        const double dw = fabs(b.w_hat) - fabs(prev_w);
        if ((dg > 1e-9 && dw < -1e-6) || (dg < -1e-9 && dw > 1e-6)) ++s.g_reversals;
        const double mh = fabs(fs_test_wrap(b.theta_hat - prev_hat - dtheta));
        const double mb = fabs(fs_test_wrap(b.theta_blnd - prev_blnd - dtheta));
        if (mh > s.max_dth_hat) s.max_dth_hat = mh;
        if (mb > s.max_dth_blnd) s.max_dth_blnd = mb;
        prev_hat = b.theta_hat;
        prev_blnd = b.theta_blnd;
        prev_g = b.g_w;
        prev_w = b.w_hat;

        const double e_hfi = fabs(fs_test_wrap(th_hfi - b.theta_hat)), e_smo = fabs(fs_test_wrap(th_smo - b.theta_hat));
        if (t < 0.14 && e_hfi > err_hfi_low) err_hfi_low = e_hfi;         /* |w| < 90 */
        if (t > 0.55 && t < 0.60 && e_smo > err_smo_hold) err_smo_hold = e_smo;
        if (t > 1.10 && e_smo > err_smo_end) err_smo_end = e_smo;
        /* |w| < 50, 11-15 time constants after leaving the band */
        if (t > 0.805 && t < 0.825 && e_hfi > err_hfi_zero) err_hfi_zero = e_hfi;
        if (t > 0.55 && t < 0.60) g_at_hold = b.g_w;
        if (t > 0.70 && t < 0.90 && b.g_w < g_min_mid) g_min_mid = b.g_w;
    }
    /* a hard switch would move the blended angle by delta in one step */
    printf("transition band %.0f-%.0f rad/s, offset %.2f rad: max |dg| %.2e/step, theta_hat extra step %.2e rad, "
           "theta_blnd extra step %.2e rad, %d reversals, %d wraps, %d straddling steps; "
           "err to HFI at low speed %.1e, to SMO at +400 %.1e, at -400 %.1e, to HFI through zero %.1e\n",
           (double)c.w_lower, (double)c.w_upper, delta, s.max_dg, s.max_dth_hat, s.max_dth_blnd,
           s.g_reversals, wraps, straddles, err_hfi_low, err_smo_hold, err_smo_end, err_hfi_zero);
    FS_CHECK(wraps > 20 && straddles > 100, "the run should cross +-pi with the sources either side (%d, %d)",
             wraps, straddles);
    FS_CHECK(g_at_hold == 1.0 && b.g_w == 1.0f, "g = 1 at |w| = 400: %.6g, %.6g", g_at_hold, (double)b.g_w);
    FS_CHECK(g_min_mid == 0.0, "g back to 0 through zero speed: %.6g", g_min_mid);
    FS_CHECK(err_hfi_low < 1e-5, "below the band the angle is the HFI one: %.3g", err_hfi_low);
    FS_CHECK(err_smo_hold < 1e-4, "above the band the angle is the SMO one: %.3g", err_smo_hold);
    FS_CHECK(err_smo_end < 1e-4, "above the band (negative) the angle is the SMO one: %.3g", err_smo_end);
    const double jump_switch = b.obs.l_theta * delta;  /* what a hard switch does to theta_hat */
    if (expect_smooth) {
        FS_CHECK(err_hfi_zero < 1e-4, "through zero speed the angle is the HFI one: %.3g", err_hfi_zero);
        /* g follows the observer's speed through eq. (28): per step
         * |alpha| Ts / band (1.9e-3 at 2000 rad/s^2), plus the speed the
         * blend adds itself, delta dg/dt, which the observer passes with up
         * to 3 w_o of slope: a positive coupling when the SMO angle leads,
         * here less than doubling it. */
        const double band = c.w_upper - c.w_lower;
        const double dg_bound = 2.0 * (2000.0 * Ts) / band;
        FS_CHECK(s.max_dg < dg_bound, "g moved by %.3g in one step (bound %.3g)", s.max_dg, dg_bound);
        FS_CHECK(s.g_reversals == 0, "g moved against the speed %d times", s.g_reversals);
        /* no jump: the blended angle moves beyond the true motion by at most
         * delta |dg|; the filtered one by that and the 20.6 % overshoot of
         * the (s + w_o)^3 step response (the speed of theta_hat responds to
         * a speed step as theta_hat to an angle step) */
        FS_CHECK(s.max_dth_blnd <= delta * s.max_dg * 1.01 + 1e-5, "blended angle steps %.3g (delta |dg| = %.3g)",
                 s.max_dth_blnd, delta * s.max_dg);
        FS_CHECK(s.max_dth_hat <= 1.25 * delta * s.max_dg + 1e-5, "filtered angle steps %.3g (delta |dg| = %.3g)",
                 s.max_dth_hat, delta * s.max_dg);
        FS_CHECK(s.max_dth_hat < 0.1 * jump_switch, "filtered angle step %.3g rad, a switch gives %.3g",
                 s.max_dth_hat, jump_switch);
    } else {
        FS_CHECK_NEAR(s.max_dth_hat, jump_switch, 0.1 * jump_switch, "hard switch: theta_hat steps l_theta delta");
        /* the contrast case: a 0.01 rad/s band is a hard switch */
        FS_CHECK(s.max_dth_blnd > 0.9 * delta, "a hard switch should jump by delta: %.3g", s.max_dth_blnd);
    }
}

/* At standstill (g = 0) the SMO angle may be anything, NaN included. */
static void check_standstill_ignores_smo(void)
{
    fs_blend b;
    fs_blend_config c = cfg0();
    fs_blend_init(&b, &c);
    fs_blend_reset(&b, 1.0f, 0.0f);
    for (int k = 0; k < 2000; ++k) fs_blend_step(&b, NAN, 1.2f, 0.0f);
    FS_CHECK(isfinite(b.theta_hat) && isfinite(b.w_hat), "NaN from the unused SMO angle");
    FS_CHECK_NEAR(b.theta_hat, 1.2, 1e-3, "follows the HFI angle at standstill");
    FS_CHECK(b.g_w == 0.0f, "g at standstill %.6g", (double)b.g_w);
}

int main(void)
{
    check_init();
    check_weight();
    check_angle();
    check_transition(0.2f, 1);
    /* contrast: a near-zero band (hard switch at 104.7 rad/s) */
    check_transition(0.1f + 1e-5f, 0);
    check_standstill_ignores_smo();
    return fs_test_summary("test_blend");
}
