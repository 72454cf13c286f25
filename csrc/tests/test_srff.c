/* fs-test-sources: control/fs_srff.c control/fs_transforms.c control/fs_status.c
 *
 * fs_srff, the band-stop SRFF of yang2022 eq. (25) / Fig. 4a:
 *   H(s) = (s - j w_x) / (s + w_b - j w_x).
 * Init validation; the switch-on transient (1 + a)/2 a^k (pole
 * a = exp(-w_b Ts)); the steady response to rotating tones against the exact
 * discrete response of fs_srff.h
 *   H_d = (1 + a)/2 (1 - z^-1) / (1 - a z^-1),  z = e^{j (w - w_x) Ts}
 * (float rounding only) and against eq. (25) (discretisation tolerance);
 * removal of a tone at w_x, positive, negative, zero and time-varying w_x;
 * angles given wrapped or off by multiples of 2 pi give the same output.
 */
#include <complex.h>
#include <math.h>

#include "control/fs_math.h"
#include "control/fs_srff.h"
#include "tests/fs_test.h"

/* Eq. (25) at s = j w. */
static double complex H_c(double w, double w_x, double w_b)
{
    return (I * w - I * w_x) / (I * w + w_b - I * w_x);
}

/* The discretisation of fs_srff.h at the frame frequency v = w - w_x. */
static double complex H_d(double w, double w_x, double w_b, double Ts)
{
    double a = exp(-w_b * Ts);
    double complex zi = cexp(-I * (w - w_x) * Ts);
    return 0.5 * (1.0 + a) * (1.0 - zi) / (1.0 - a * zi);
}

static fs_ab to_ab(double complex z)
{
    fs_ab x = {(float)creal(z), (float)cimag(z)};
    return x;
}

static double complex to_c(fs_ab x) { return x.alpha + I * x.beta; }

/* Steady complex gain y/x of a unit tone at w through the SRFF at w_x:
 * run 25 time constants, then average y/x over 400 samples; *spread is the
 * largest deviation of y/x from that mean in the window (0 for an LTI
 * steady state, float rounding here). */
static double complex measure(float Ts, float w_b, double w_x, double w, double *spread)
{
    fs_srff f;
    fs_srff_config c = {Ts, w_b};
    FS_CHECK(fs_srff_init(&f, &c) == FS_OK, "init");
    int settle = (int)(25.0 / (w_b * Ts)) + 10;
    const int M = 400;
    double complex sum = 0.0, r[400];
    for (int k = 0; k < settle + M; ++k) {
        double t = k * (double)Ts;
        double complex x = cexp(I * (w * t + 0.7));
        fs_ab y = fs_srff_step(&f, to_ab(x), (float)fs_test_wrap(w_x * t - 1.1));
        if (k >= settle) {
            r[k - settle] = to_c(y) / x;
            sum += r[k - settle];
        }
    }
    double complex mean = sum / M;
    *spread = 0.0;
    for (int k = 0; k < M; ++k) {
        if (cabs(r[k] - mean) > *spread) *spread = cabs(r[k] - mean);
    }
    return mean;
}

/* Largest |y| over the last `window` of n steps for a tone of amplitude A that
 * follows theta_x (the removed component), theta_x from w_x(t) integrated in
 * double and wrapped. w_x(t) = w0 + ramp t. */
static double residual_tracked(float Ts, float w_b, double w0, double ramp, double A, int n,
                               int window, int freeze_frame)
{
    fs_srff f;
    fs_srff_config c = {Ts, w_b};
    fs_srff_init(&f, &c);
    double th = 0.4, worst = 0.0;
    for (int k = 0; k < n; ++k) {
        double t = k * (double)Ts;
        double complex x = A * cexp(I * th);
        /* freeze_frame: the frame turns at the initial w0 instead of following. */
        double th_frame = freeze_frame ? 0.4 + w0 * t : th;
        fs_ab y = fs_srff_step(&f, to_ab(x), (float)fs_test_wrap(th_frame));
        if (k >= n - window && hypot(y.alpha, y.beta) > worst) worst = hypot(y.alpha, y.beta);
        th = fs_test_wrap(th + (w0 + ramp * (t + 0.5 * Ts)) * Ts);  /* exact for the linear ramp */
    }
    return worst;
}

int main(void)
{
    const float Ts = 1e-4f;
    const double w_h = 2.0 * FS_TEST_PI * 1000.0;

    /* ---- init ---- */
    fs_srff f;
    fs_srff_config c = {Ts, 628.0f};
    FS_CHECK_EQ_INT(fs_srff_init(&f, &c), FS_OK, "init");
    FS_CHECK_NEAR(f.a, exp(-628.0 * 1e-4), 1e-7, "a = exp(-w_b Ts)");
    FS_CHECK_NEAR(f.b, 1.0 - exp(-628.0 * 1e-4), 1e-7, "b = 1 - a");
    FS_CHECK_NEAR(f.g, 0.5 * (1.0 + exp(-628.0 * 1e-4)), 1e-7, "g = (1 + a)/2");
    FS_CHECK(f.lp.d == 0.0f && f.lp.q == 0.0f, "init clears the state");
    FS_CHECK_EQ_INT(fs_srff_init(NULL, &c), FS_ERR_NULL, "null filter");
    FS_CHECK_EQ_INT(fs_srff_init(&f, NULL), FS_ERR_NULL, "null config");
    const float bad_ts[] = {0.0f, -1e-4f, NAN, INFINITY};
    for (int k = 0; k < 4; ++k) {
        fs_srff_config b = c;
        b.Ts = bad_ts[k];
        FS_CHECK_EQ_INT(fs_srff_init(&f, &b), FS_ERR_TS, "bad Ts");
    }
    const float bad_wb[] = {0.0f, -10.0f, NAN, INFINITY, 5001.0f /* w_b Ts > 0.5 */};
    for (int k = 0; k < 5; ++k) {
        fs_srff_config b = c;
        b.w_b = bad_wb[k];
        FS_CHECK_EQ_INT(fs_srff_init(&f, &b), FS_ERR_BANDWIDTH, "bad w_b");
    }
    {
        fs_srff_config b = {Ts, 5000.0f};  /* w_b Ts = 0.5: the limit itself is allowed */
        FS_CHECK_EQ_INT(fs_srff_init(&f, &b), FS_OK, "w_b Ts = 0.5");
    }

    /* ---- switch-on transient: y[k] = (1 + a)/2 a^k x[k] for a tone at w_x ---- */
    {
        const float w_b = 628.0f;
        fs_srff_config cc = {Ts, w_b};
        fs_srff_init(&f, &cc);
        double a = exp(-(double)w_b * Ts), worst = 0.0;
        for (int k = 0; k < 200; ++k) {
            double th = fs_test_wrap(w_h * k * (double)Ts + 0.3);
            double complex x = 10.5 * cexp(I * th);
            fs_ab y = fs_srff_step(&f, to_ab(x), (float)th);
            double err = cabs(to_c(y) - 0.5 * (1.0 + a) * pow(a, k) * x);
            if (err > worst) worst = err;
        }
        printf("switch-on: max |y - (1 + a)/2 a^k x| = %.3g (amplitude 10.5)\n", worst);
        FS_CHECK(worst < 1e-4, "switch-on transient is not (1 + a)/2 a^k x: %.3g", worst);
        /* reset: the next output is (1 + a)/2 times the input */
        fs_srff_reset(&f);
        fs_ab x = {3.0f, -2.0f};
        fs_ab y = fs_srff_step(&f, x, 1.0f);
        FS_CHECK(y.alpha == f.g * x.alpha && y.beta == f.g * x.beta, "after reset y = g x (%g, %g)", y.alpha, y.beta);
    }

    /* ---- steady response to tones ---- */
    /* Tolerance against eq. (25): H_c = 1/(1 + e_c), e_c = w_b/(j v), and
     * H_d = 1/(1 + e') with e' = w_b'/(j v'), w_b' = (2/Ts) tanh(w_b Ts/2),
     * v' = (2/Ts) tan(v Ts/2) (fs_srff.h). |1 + e| >= 1 for both, so
     * |H_d - H_c| <= |e_c - e'| = (w_b/|v|) |1 - (w_b'/w_b)(v/v')|
     *              <= (w_b/|v|) ((w_b Ts)^2 + (v Ts)^2)/12 (1 + higher order);
     * 1.2 covers the higher order up to |v Ts| = 1.3 (tan: 0.136 vs 0.132). */
    {
        const float wbs[] = {314.0f, 628.0f, 1500.0f};
        const double wxs[] = {w_h, -w_h, -w_h + 200.0, 0.0};
        double worst_d = 0.0, worst_c_rel = 0.0, worst_gain = 0.0, worst_phase = 0.0, worst_rej = 0.0;
        for (int ib = 0; ib < 3; ++ib) {
            for (int ix = 0; ix < 4; ++ix) {
                const double w_b = wbs[ib], w_x = wxs[ix];
                /* the stop frequency, its edges, its mirror, far away, the fundamental */
                const double ws[] = {w_x, w_x + w_b, w_x - w_b, w_x + 3.0 * w_b, -w_x, w_x + 0.6 * w_h,
                                     100.0, -w_x + 200.0};
                for (int iw = 0; iw < 8; ++iw) {
                    const double w = ws[iw], v = w - w_x;
                    if (iw > 0 && fabs(v) < 1.0) continue;  /* w_x = 0: -w_x is w_x */
                    double spread;
                    double complex g = measure(Ts, wbs[ib], w_x, w, &spread);
                    double complex gd = H_d(w, w_x, w_b, Ts), gc = H_c(w, w_x, w_b);
                    FS_CHECK(spread < 2e-5, "w_b %g w_x %g w %g: not steady (spread %.3g)", w_b, w_x, w, spread);
                    if (iw == 0) {
                        /* the removed tone: < 1e-3 of its amplitude (float: ~1e-6) */
                        FS_CHECK(cabs(g) < 1e-3, "w_b %g w_x %g: tone at w_x left at %.3g", w_b, w_x, cabs(g));
                        if (cabs(g) > worst_rej) worst_rej = cabs(g);
                        continue;
                    }
                    double ed = cabs(g - gd);
                    if (ed > worst_d) worst_d = ed;
                    FS_CHECK(ed < 1e-5, "w_b %g w_x %g w %g: |H - H_d| = %.3g", w_b, w_x, w, ed);  /* float rounding */
                    double tol = 1.2 * (w_b / fabs(v)) * ((w_b * Ts) * (w_b * Ts) + (v * Ts) * (v * Ts)) / 12.0 + 1e-5;
                    double ec = cabs(g - gc);
                    if (ec / tol > worst_c_rel) worst_c_rel = ec / tol;
                    FS_CHECK(ec <= tol, "w_b %g w_x %g w %g: |H - eq.(25)| = %.4g > %.4g (H %.4f%+.4fj, eq.(25) %.4f%+.4fj)",
                             w_b, w_x, w, ec, tol, creal(g), cimag(g), creal(gc), cimag(gc));
                    double dg = cabs(g) / cabs(gc) - 1.0, dp = carg(g / gc);
                    if (fabs(dg) > worst_gain) worst_gain = fabs(dg);
                    if (fabs(dp) > worst_phase) worst_phase = fabs(dp);
                }
            }
        }
        printf("tones: removed tone at w_x left at %.3g of its amplitude; |H - H_d| <= %.3g; "
               "|H - eq.(25)| <= %.2f of the tolerance; gain error vs eq.(25) <= %.4f, phase <= %.4f rad\n",
               worst_rej, worst_d, worst_c_rel, worst_gain, worst_phase);

        /* Spot values that pin the shape of eq. (25) itself (w_b = 314, w_x = w_h):
         * at the band edges the warping is (w_b Ts)^2/12 ~ 1e-4. */
        double spread;
        double complex g = measure(Ts, 314.0f, w_h, w_h + 314.0, &spread);  /* band edge */
        double complex g2 = measure(Ts, 314.0f, w_h, w_h - 314.0, &spread);
        printf("band edges w_x -+ w_b: gain %.5f, %.5f, phase %+.5f, %+.5f rad (eq.(25): 0.70711, +-0.78540)\n",
               cabs(g2), cabs(g), carg(g2), carg(g));
        FS_CHECK_NEAR(cabs(g), 1.0 / sqrt(2.0), 2e-3, "gain at the band edge w_x + w_b");
        FS_CHECK_NEAR(carg(g), FS_TEST_PI / 4.0, 2e-3, "phase lead pi/4 at w_x + w_b");
        FS_CHECK_NEAR(cabs(g2), 1.0 / sqrt(2.0), 2e-3, "gain at the band edge w_x - w_b");
        FS_CHECK_NEAR(carg(g2), -FS_TEST_PI / 4.0, 2e-3, "phase lag pi/4 at w_x - w_b");
        g = measure(Ts, 314.0f, w_h, -w_h, &spread);  /* mirror: passes, |H| ~ 1 */
        printf("mirror -w_x (w_b = 314): gain %.5f, phase %.5f rad; eq.(25): %.5f, %.5f rad\n",
               cabs(g), carg(g), cabs(H_c(-w_h, w_h, 314.0)), carg(H_c(-w_h, w_h, 314.0)));
        FS_CHECK_NEAR(cabs(g), 1.0, 1e-3, "mirror frequency passes");
        /* the warping shrinks the 0.025 rad of eq. (25) by (v Ts)^2/12 = 13 % */
        FS_CHECK_NEAR(carg(g), carg(H_c(-w_h, w_h, 314.0)), 5e-3, "mirror frequency phase");
    }

    /* ---- time-varying w_x: a tone that follows theta_x is still removed ---- */
    {
        const int n = 10000;  /* 1 s */
        /* w_x from -w_h to +w_h through 0 in 1 s (ramp 2 w_h per second), and a
         * slow one around the negative carrier (-w_h + 2 w_r, w_r ramping 0 -> 300) */
        double r1 = residual_tracked(Ts, 628.0f, -w_h, 2.0 * w_h, 10.5, n, 8000, 0);
        double r2 = residual_tracked(Ts, 628.0f, -w_h, 600.0, 1.7, n, 8000, 0);
        double r3 = residual_tracked(Ts, 314.0f, 2000.0, -4000.0, 1.0, n, 8000, 0);
        /* the same tone with the frame at the initial frequency: not removed */
        double r1f = residual_tracked(Ts, 628.0f, -w_h, 2.0 * w_h, 10.5, n, 8000, 1);
        printf("ramping w_x: residual %.3g (of 10.5), %.3g (of 1.7), %.3g (of 1); frozen frame %.3g (of 10.5)\n",
               r1, r2, r3, r1f);
        FS_CHECK(r1 < 1e-3 * 10.5, "ramping w_x through 0: residual %.3g", r1);
        FS_CHECK(r2 < 1e-3 * 1.7, "slowly ramping w_x: residual %.3g", r2);
        FS_CHECK(r3 < 1e-3 * 1.0, "decreasing w_x: residual %.3g", r3);
        FS_CHECK(r1f > 5.0, "frame not following: the tone should pass (%.3g)", r1f);
    }

    /* ---- wrap: theta_x and theta_x + 2 pi m[k] give the same output ---- */
    {
        fs_srff fa, fb;
        fs_srff_config cc = {Ts, 628.0f};
        fs_srff_init(&fa, &cc);
        fs_srff_init(&fb, &cc);
        uint32_t seed = 12345u;
        double worst = 0.0, worst_rej = 0.0;
        int crossings = 0;
        float prev = 0.0f;
        for (int k = 0; k < 20000; ++k) {
            double t = k * (double)Ts;
            double th = fs_test_wrap(-w_h * t + 2.0 * 100.0 * t);  /* negative-carrier angle */
            double complex x = 1.7 * cexp(I * th) + 5.0 * cexp(I * (100.0 * t + 0.2))
                               + 10.5 * cexp(I * (w_h * t - FS_TEST_PI / 2));
            seed = seed * 1664525u + 1013904223u;
            int m = (int)(seed >> 29) - 4;  /* -4 .. 3 */
            float th_w = (float)th;
            float th_u = (float)(th + 2.0 * FS_TEST_PI * m);
            if (k > 0 && fabsf(th_w - prev) > FS_PI) ++crossings;
            prev = th_w;
            fs_ab ya = fs_srff_step(&fa, to_ab(x), th_w);
            fs_ab yb = fs_srff_step(&fb, to_ab(x), th_u);
            double d = hypot(ya.alpha - yb.alpha, ya.beta - yb.beta);
            if (d > worst) worst = d;
            if (k > 10000) {
                /* what is left of the tone at theta: the output minus the two others */
                double complex rest = to_c(ya) - 5.0 * cexp(I * (100.0 * t + 0.2)) * H_d(100.0, -w_h + 200.0, 628.0, Ts)
                                      - 10.5 * cexp(I * (w_h * t - FS_TEST_PI / 2)) * H_d(w_h, -w_h + 200.0, 628.0, Ts);
                if (cabs(rest) > worst_rej) worst_rej = cabs(rest);
            }
        }
        /* The unwrapped float angle (|theta| <= 8 pi) is rounded to 2e-6 rad: the
         * outputs differ by about 17 A * 2e-6 per step, not accumulated. */
        printf("wrap: %d crossings of +-pi; max |y_wrapped - y_shifted| = %.3g; tone left %.3g (of 1.7)\n",
               crossings, worst, worst_rej);
        FS_CHECK(crossings > 100, "the angle should cross +-pi (%d)", crossings);
        FS_CHECK(worst < 1e-4, "wrapped vs shifted angles: outputs differ by %.3g", worst);
        FS_CHECK(worst_rej < 1e-3 * 1.7, "tone at theta_x left at %.3g", worst_rej);
    }
    return fs_test_summary("test_srff");
}
