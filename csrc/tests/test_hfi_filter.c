/* fs-test-sources: control/fs_hfi_filter.c control/fs_srff.c control/fs_transforms.c control/fs_status.c
 *
 * fs_hfi_filter, the subtraction-based current filter of yang2022 Fig. 4b, on
 * the synthetic current of eq. (24): fundamental A_f e^{j(theta_r + phi)} at
 * w_f + positive carrier I_p e^{j(w_h t - pi/2)} + negative carrier
 * I_n e^{j(-w_h t + 2 theta_r + pi/2)}, w_h = 2 pi 1 kHz, Ts = 1e-4 s,
 * I_p = 10.5 A, I_n = 1.7 A, w_f = 2 pi 16 Hz (~100 rad/s), A_f = 5 A.
 * Bandwidths: the header's default rule w_b_p = w_b_n = w_h / 10.
 *
 * The measuring window is 0.125 s after 0.15 s (94 time constants) of
 * settling: it holds whole periods of 16, 1000 and -968 Hz, so projecting an
 * output on each component's phasor gives that component's complex gain
 * exactly. Checks: the outputs against the exact discrete prediction (the
 * composition of the two SRFF responses H_d of fs_srff.h, float rounding
 * only), against the ideal split (tolerances from eq. (25) below), the
 * structure (i_f = SRFF_n(SRFF_p(i)), i_hn = SRFF_p(i) - i_f), a constant and
 * a speed error in theta_r_hat, the +-pi wrap, reset and init.
 */
#include <complex.h>
#include <math.h>

#include "control/fs_hfi_filter.h"
#include "control/fs_math.h"
#include "tests/fs_test.h"

static const float TS = 1e-4f;
static const double W_H = 2.0 * FS_TEST_PI * 1000.0;
static const double W_F = 2.0 * FS_TEST_PI * 16.0;
static const double I_P = 10.5, I_N = 1.7;
static const int N_SETTLE = 1500, N_WIN = 1250;

static fs_ab to_ab(double complex z)
{
    fs_ab x = {(float)creal(z), (float)cimag(z)};
    return x;
}

static double complex to_c(fs_ab x) { return x.alpha + I * x.beta; }

/* eq. (25) at s = j w, and its discretisation (fs_srff.h). */
static double complex H_c(double w, double w_x, double w_b)
{
    return (I * w - I * w_x) / (I * w + w_b - I * w_x);
}

static double complex H_d(double w, double w_x, double w_b)
{
    double a = exp(-w_b * TS);
    double complex zi = cexp(-I * (w - w_x) * TS);
    return 0.5 * (1.0 + a) * (1.0 - zi) / (1.0 - a * zi);
}

typedef struct {
    double A_f, phi_f;      /* fundamental amplitude and angle from theta_r */
    double th_r0;           /* rotor angle at t = 0 */
    double d_theta;         /* theta_r_hat - theta_r, constant part */
    double d_w;             /* w_r_hat - w_r */
    float w_b_p, w_b_n;
    int shift_angles;       /* add 2 pi m[k] to the angles given to the filter */
} scen;

/* Complex gains of each component (fundamental, positive, negative carrier)
 * in each output, and time-domain errors over the window. */
typedef struct {
    double complex f[3], hn[3];       /* measured */
    double complex pf[3], phn[3];     /* exact discrete prediction */
    double complex cf[3], chn[3];     /* eq. (25) */
    double err_pred_f, err_pred_hn;   /* max |output - exact prediction| */
    double err_ideal_f, err_ideal_hn; /* max |i_f - fundamental|, |i_hn - negative carrier| */
    double eps_mean;                  /* mean heterodyne error, eq. (26), normalised by I_n */
    fs_ab last_f, last_hn;
} result;

static void run(const scen *s, result *r, fs_ab *trace_f, fs_ab *trace_hn)
{
    fs_hfi_filter f;
    fs_hfi_filter_config c = {TS, s->w_b_p, s->w_b_n};
    FS_CHECK(fs_hfi_filter_init(&f, &c) == FS_OK, "init");
    const double w_n_hat = -W_H + 2.0 * (W_F + s->d_w);   /* stop frequency of SRFF_n */
    const double w[3] = {W_F, W_H, -W_H + 2.0 * W_F};
    const double amp[3] = {s->A_f, I_P, I_N};
    for (int m = 0; m < 3; ++m) {
        double complex g1d = H_d(w[m], W_H, s->w_b_p), g2d = H_d(w[m], w_n_hat, s->w_b_n);
        double complex g1c = H_c(w[m], W_H, s->w_b_p), g2c = H_c(w[m], w_n_hat, s->w_b_n);
        r->pf[m] = g1d * g2d;
        r->phn[m] = g1d * (1.0 - g2d);
        r->cf[m] = g1c * g2c;
        r->chn[m] = g1c * (1.0 - g2c);
        r->f[m] = r->hn[m] = 0.0;
    }
    r->err_pred_f = r->err_pred_hn = r->err_ideal_f = r->err_ideal_hn = r->eps_mean = 0.0;
    uint32_t seed = 777u;
    for (int k = 0; k < N_SETTLE + N_WIN; ++k) {
        double t = k * (double)TS;
        double th_r = W_F * t + s->th_r0;
        double ph[3] = {th_r + s->phi_f, W_H * t - FS_TEST_PI / 2, -W_H * t + 2.0 * th_r + FS_TEST_PI / 2};
        double complex comp[3], i = 0.0;
        for (int m = 0; m < 3; ++m) {
            comp[m] = amp[m] * cexp(I * ph[m]);
            i += comp[m];
        }
        double th_h = fs_test_wrap(W_H * t);
        double th_hat = fs_test_wrap(th_r + s->d_theta + s->d_w * t);
        if (s->shift_angles) {
            seed = seed * 1664525u + 1013904223u;
            th_h += 2.0 * FS_TEST_PI * ((int)(seed >> 30) - 2);         /* -2 .. 1 */
            th_hat += 2.0 * FS_TEST_PI * ((int)((seed >> 27) & 3u) - 1); /* -1 .. 2 */
        }
        fs_ab i_f, i_hn;
        fs_hfi_filter_step(&f, to_ab(i), (float)th_h, (float)th_hat, &i_f, &i_hn);
        if (trace_f) trace_f[k] = i_f;
        if (trace_hn) trace_hn[k] = i_hn;
        r->last_f = i_f;
        r->last_hn = i_hn;
        if (k < N_SETTLE) continue;
        double complex yf = to_c(i_f), yhn = to_c(i_hn), pf = 0.0, phn = 0.0;
        for (int m = 0; m < 3; ++m) {
            r->f[m] += yf * cexp(-I * ph[m]) / (amp[m] > 0.0 ? amp[m] : 1.0) / N_WIN;
            r->hn[m] += yhn * cexp(-I * ph[m]) / (amp[m] > 0.0 ? amp[m] : 1.0) / N_WIN;
            pf += r->pf[m] * comp[m];
            phn += r->phn[m] * comp[m];
        }
        r->err_pred_f = fmax(r->err_pred_f, cabs(yf - pf));
        r->err_pred_hn = fmax(r->err_pred_hn, cabs(yhn - phn));
        r->err_ideal_f = fmax(r->err_ideal_f, cabs(yf - comp[0]));
        r->err_ideal_hn = fmax(r->err_ideal_hn, cabs(yhn - comp[2]));
        /* eq. (26): e^{j(-w_h t + 2 theta_r_hat + pi/2)} x i_hn / I_n */
        double complex u = cexp(I * (-W_H * t + 2.0 * (th_r + s->d_theta + s->d_w * t) + FS_TEST_PI / 2));
        r->eps_mean += cimag(conj(u) * yhn) / I_N / N_WIN;
    }
}

int main(void)
{
    const float w_b = (float)(W_H / 10.0);  /* the header's default rule */

    /* ---- init ---- */
    fs_hfi_filter f;
    fs_hfi_filter_config c = {TS, w_b, w_b};
    FS_CHECK_EQ_INT(fs_hfi_filter_init(&f, &c), FS_OK, "init");
    FS_CHECK_EQ_INT(fs_hfi_filter_init(NULL, &c), FS_ERR_NULL, "null filter");
    FS_CHECK_EQ_INT(fs_hfi_filter_init(&f, NULL), FS_ERR_NULL, "null config");
    const float bad_ts[] = {0.0f, -1e-4f, NAN, INFINITY};
    for (int k = 0; k < 4; ++k) {
        fs_hfi_filter_config b = c;
        b.Ts = bad_ts[k];
        FS_CHECK_EQ_INT(fs_hfi_filter_init(&f, &b), FS_ERR_TS, "bad Ts");
    }
    const float bad_wb[] = {0.0f, -10.0f, NAN, 5001.0f /* w_b Ts > 0.5 */};
    for (int k = 0; k < 4; ++k) {
        fs_hfi_filter_config b = c;
        b.w_b_p = bad_wb[k];
        FS_CHECK_EQ_INT(fs_hfi_filter_init(&f, &b), FS_ERR_BANDWIDTH, "bad w_b_p");
        b = c;
        b.w_b_n = bad_wb[k];
        FS_CHECK_EQ_INT(fs_hfi_filter_init(&f, &b), FS_ERR_BANDWIDTH, "bad w_b_n");
    }
    {
        fs_hfi_filter_config b = {TS, 100.0f, 900.0f};
        FS_CHECK_EQ_INT(fs_hfi_filter_init(&f, &b), FS_OK, "different bandwidths");
        FS_CHECK_NEAR(f.srff_p.a, exp(-100.0 * 1e-4), 1e-7, "w_b_p goes to the positive-carrier SRFF");
        FS_CHECK_NEAR(f.srff_n.a, exp(-900.0 * 1e-4), 1e-7, "w_b_n goes to the negative-carrier SRFF");
    }

    /* ---- the nominal split, theta_r_hat = theta_r ---- */
    scen s0 = {5.0, 1.8, 0.2, 0.0, 0.0, w_b, w_b, 0};
    result r0;
    static fs_ab tf0[2750], thn0[2750];
    run(&s0, &r0, tf0, thn0);
    printf("nominal: |i_f - predicted| <= %.3g A, |i_hn - predicted| <= %.3g A\n", r0.err_pred_f, r0.err_pred_hn);
    printf("  i_f : fundamental gain %.5f phase %+.2e rad (eq.(25) %.5f %+.2e); carriers left %.2e, %.2e of I_p, I_n\n",
           cabs(r0.f[0]), carg(r0.f[0]), cabs(r0.cf[0]), carg(r0.cf[0]), cabs(r0.f[1]), cabs(r0.f[2]));
    printf("  i_hn: neg. carrier gain %.5f phase %+.4f rad (eq.(25) %.5f %+.4f) -> eq.(26) nulls at theta_r - theta_r_hat = %+.4f rad;\n"
           "        fundamental leak %.4f of A_f (eq.(25) %.4f), positive carrier %.2e of I_p\n",
           cabs(r0.hn[2]), carg(r0.hn[2]), cabs(r0.chn[2]), carg(r0.chn[2]), -carg(r0.hn[2]) / 2.0,
           cabs(r0.hn[0]), cabs(r0.chn[0]), cabs(r0.hn[1]));
    printf("  max |i_f - fundamental| = %.4f A, max |i_hn - negative carrier| = %.4f A, eq.(26) error %+.4f\n",
           r0.err_ideal_f, r0.err_ideal_hn, r0.eps_mean);
    /* Implementation = the composition of the two discrete SRFFs: float
     * rounding of ~17 A of input through 1/(1-a) = 16 of state gain: 1e-3 A. */
    FS_CHECK(r0.err_pred_f < 1e-3, "i_f differs from the exact prediction by %.3g A", r0.err_pred_f);
    FS_CHECK(r0.err_pred_hn < 1e-3, "i_hn differs from the exact prediction by %.3g A", r0.err_pred_hn);
    for (int m = 0; m < 3; ++m) {
        FS_CHECK(cabs(r0.f[m] - r0.pf[m]) < 1e-4, "i_f component %d: %.3g from the prediction", m, cabs(r0.f[m] - r0.pf[m]));
        FS_CHECK(cabs(r0.hn[m] - r0.phn[m]) < 1e-4, "i_hn component %d: %.3g from the prediction", m, cabs(r0.hn[m] - r0.phn[m]));
    }
    /* Both carriers are gone from i_f, the positive one from i_hn (stop bands). */
    FS_CHECK(cabs(r0.f[1]) < 1e-4, "positive carrier left in i_f: %.3g", cabs(r0.f[1]));
    FS_CHECK(cabs(r0.f[2]) < 1e-4, "negative carrier left in i_f: %.3g", cabs(r0.f[2]));
    FS_CHECK(cabs(r0.hn[1]) < 1e-4, "positive carrier in i_hn: %.3g", cabs(r0.hn[1]));
    /* Departures from eq. (25) are the frequency warping of fs_srff.h: at most
     * (w_b/|v|)(v Ts)^2/12 (1.2 with higher order) with |v Ts| <= 1.25 here,
     * i.e. 0.013 w_b/|v| per SRFF: 0.002 at the fundamental (w_b/|v| = 0.1
     * in both), 0.008 on the negative carrier through H_p (0.05), 0.01 on the
     * leak (1 - H_n is 0.1 and shifts with H_n). */
    /* Fundamental in i_f: H_p and H_n see it at -(w_h - w_f) and +(w_h - w_f),
     * their phases cancel (exactly, also discretised: H_n = conj(H_p) there);
     * eq. (25) gives the gain 1/(1 + (w_b/(w_h - w_f))^2) = 0.990. */
    FS_CHECK(fabs(carg(r0.f[0])) < 1e-4, "fundamental phase in i_f %.3g (should cancel)", carg(r0.f[0]));
    FS_CHECK_NEAR(cabs(r0.f[0]), 1.0, 0.015, "fundamental gain in i_f");
    FS_CHECK_NEAR(cabs(r0.f[0]), cabs(r0.cf[0]), 0.002, "fundamental gain in i_f vs eq. (25)");
    /* Negative carrier in i_hn: H_p at -2(w_h - w_f) distorts it by
     * w_b/(2(w_h - w_f)) = 0.051, mostly in phase (eq. (25)). */
    FS_CHECK(cabs(r0.hn[2] - 1.0) < 0.06, "negative carrier in i_hn off by %.4f", cabs(r0.hn[2] - 1.0));
    FS_CHECK(cabs(r0.hn[2] - r0.chn[2]) < 0.008, "negative carrier in i_hn vs eq. (25): %.4f", cabs(r0.hn[2] - r0.chn[2]));
    /* Fundamental leak into i_hn: |1 - H_n| ~ w_b/(w_h - w_f) = 0.1. */
    FS_CHECK_NEAR(cabs(r0.hn[0]), cabs(r0.chn[0]), 0.01, "fundamental leak into i_hn vs eq. (25)");
    /* Time domain: i_f is the fundamental within its 1 % gain error (1.5 %
     * allowed); i_hn is the negative carrier within 0.06 I_n plus the
     * fundamental leak 0.11 A_f (0.10 A + 0.55 A: the leak dominates, a
     * ripple near w_h after the heterodyne of eq. (26), left to the observer). */
    FS_CHECK(r0.err_ideal_f < 0.015 * s0.A_f, "|i_f - fundamental| = %.4f A", r0.err_ideal_f);
    FS_CHECK(r0.err_ideal_hn < 0.06 * I_N + 0.11 * s0.A_f, "|i_hn - negative carrier| = %.4f A", r0.err_ideal_hn);
    /* eq. (26) on i_hn with the true angle: sin(0) + the bias of H_p's phase. */
    FS_CHECK_NEAR(r0.eps_mean, cabs(r0.hn[2]) * sin(carg(r0.hn[2])), 1e-3, "eq. (26) error = bias of i_hn's phase");
    FS_CHECK(fabs(r0.eps_mean) < 0.06, "eq. (26) bias %.4f", r0.eps_mean);

    /* Without fundamental (A_f = 0) i_hn is the negative carrier within 0.06 I_n. */
    {
        scen s = s0;
        s.A_f = 0.0;
        result r;
        run(&s, &r, NULL, NULL);
        printf("A_f = 0: max |i_f| = %.2e A, max |i_hn - negative carrier| = %.4f A (%.3f of I_n)\n",
               r.err_ideal_f, r.err_ideal_hn, r.err_ideal_hn / I_N);
        FS_CHECK(r.err_ideal_f < 1e-3, "i_f without fundamental: %.3g A", r.err_ideal_f);
        FS_CHECK(r.err_ideal_hn < 0.06 * I_N, "|i_hn - negative carrier| = %.4f A", r.err_ideal_hn);
    }

    /* ---- structure: i_f = SRFF_n(SRFF_p(i)), i_hn = SRFF_p(i) - i_f ---- */
    {
        fs_hfi_filter h;
        fs_srff sp, sn;
        fs_hfi_filter_config hc = {TS, 400.0f, 700.0f};
        fs_srff_config cp = {TS, 400.0f}, cn = {TS, 700.0f};
        fs_hfi_filter_init(&h, &hc);
        fs_srff_init(&sp, &cp);
        fs_srff_init(&sn, &cn);
        uint32_t seed = 99u;
        double worst = 0.0;
        for (int k = 0; k < 3000; ++k) {
            seed = seed * 1664525u + 1013904223u;
            fs_ab i = {(float)((seed >> 8) & 0xffffu) / 3000.0f - 10.0f, (float)(seed >> 24) / 10.0f - 12.0f};
            float th_h = (float)fs_test_wrap(W_H * k * (double)TS);
            float th_hat = (float)fs_test_wrap(0.013 * k * k * (double)TS);  /* accelerating */
            fs_ab i_f, i_hn;
            fs_hfi_filter_step(&h, i, th_h, th_hat, &i_f, &i_hn);
            fs_ab y = fs_srff_step(&sp, i, th_h);
            fs_ab z = fs_srff_step(&sn, y, fs_wrap_pi(2.0f * th_hat - th_h));
            worst = fmax(worst, hypot(i_f.alpha - z.alpha, i_f.beta - z.beta));
            worst = fmax(worst, hypot(i_hn.alpha - (y.alpha - z.alpha), i_hn.beta - (y.beta - z.beta)));
        }
        FS_CHECK(worst < 1e-5, "not the structure of Fig. 4b: %.3g", worst);
    }

    /* ---- constant error in theta_r_hat: the same split, i_hn keeps the true phase ---- */
    {
        scen s = s0;
        s.d_theta = 0.3;
        result r;
        static fs_ab tf[2750], thn[2750];
        run(&s, &r, tf, thn);
        double worst = 0.0;
        for (int k = N_SETTLE; k < N_SETTLE + N_WIN; ++k) {
            worst = fmax(worst, hypot(tf[k].alpha - tf0[k].alpha, tf[k].beta - tf0[k].beta));
            worst = fmax(worst, hypot(thn[k].alpha - thn0[k].alpha, thn[k].beta - thn0[k].beta));
        }
        /* eq. (26) with theta_r_hat = theta_r + 0.3 reads sin(-0.6) (+ the bias) */
        double expect = cabs(r0.hn[2]) * sin(carg(r0.hn[2]) - 0.6);
        printf("theta_r_hat off by 0.3 rad: outputs differ from the nominal by %.2e A; eq.(26) error %+.4f (sin(-0.6) = %+.4f)\n",
               worst, r.eps_mean, sin(-0.6));
        FS_CHECK(worst < 1e-3, "a constant angle error changed the steady outputs by %.3g A", worst);
        FS_CHECK(cabs(r.hn[2] - r0.hn[2]) < 1e-4, "i_hn's negative carrier moved with theta_r_hat: %.3g", cabs(r.hn[2] - r0.hn[2]));
        FS_CHECK_NEAR(r.eps_mean, expect, 1e-3, "eq. (26) error with a 0.3 rad offset");
    }

    /* ---- speed error in theta_r_hat: i_hn is a band-pass of width w_b_n ---- */
    {
        scen s = s0;
        s.d_w = 0.5 * w_b;  /* SRFF_n sees the carrier at 2 d_w = w_b_n: band edge */
        result r;
        run(&s, &r, NULL, NULL);
        /* eq. (25): 1 - H_n = w_b/(j v + w_b) at v = -w_b: 1/sqrt(2) to i_hn, the
         * rest (also 1/sqrt(2) in size) to i_f, times H_p. */
        printf("w_r_hat off by w_b/2: negative carrier %.4f in i_hn, %.4f in i_f (eq.(25) %.4f, %.4f)\n",
               cabs(r.hn[2]), cabs(r.f[2]), cabs(r.chn[2]), cabs(r.cf[2]));
        FS_CHECK(r.err_pred_f < 1e-3 && r.err_pred_hn < 1e-3, "prediction with a speed error: %.3g, %.3g A",
                 r.err_pred_f, r.err_pred_hn);
        FS_CHECK_NEAR(cabs(r.hn[2]), 1.0 / sqrt(2.0), 0.07, "negative carrier in i_hn at the band edge");
        FS_CHECK_NEAR(cabs(r.f[2]), 1.0 / sqrt(2.0), 0.07, "negative carrier leaking into i_f at the band edge");
        /* warping: w_b/|v| = 1 in H_n ((w_b Ts)^2/12 = 3e-4), 0.05 in H_p (0.008) */
        FS_CHECK(cabs(r.hn[2] - r.chn[2]) < 0.01 && cabs(r.f[2] - r.cf[2]) < 0.01,
                 "speed error vs eq. (25): %.4f, %.4f", cabs(r.hn[2] - r.chn[2]), cabs(r.f[2] - r.cf[2]));
        FS_CHECK(cabs(r.f[1]) < 1e-4, "positive carrier still removed: %.3g", cabs(r.f[1]));
    }

    /* ---- wrap: angles off by multiples of 2 pi give the same outputs ---- */
    {
        scen s = s0;
        s.shift_angles = 1;
        result r;
        static fs_ab tf[2750], thn[2750];
        run(&s, &r, tf, thn);
        double worst = 0.0;
        for (int k = 0; k < N_SETTLE + N_WIN; ++k) {
            worst = fmax(worst, hypot(tf[k].alpha - tf0[k].alpha, tf[k].beta - tf0[k].beta));
            worst = fmax(worst, hypot(thn[k].alpha - thn0[k].alpha, thn[k].beta - thn0[k].beta));
        }
        /* angles up to 5 pi in float: rounding 1e-6 rad on 17 A */
        printf("angles shifted by 2 pi m: outputs differ by %.2e A\n", worst);
        FS_CHECK(worst < 1e-4, "shifted angles changed the outputs by %.3g A", worst);
    }

    /* ---- reset, and NULL outputs ---- */
    {
        fs_hfi_filter a, b;
        fs_hfi_filter_init(&a, &c);
        fs_hfi_filter_init(&b, &c);
        fs_ab i_f, i_hn, j_f = {0.0f, 0.0f};
        double worst = 0.0;
        for (int k = 0; k < 500; ++k) {
            double t = k * (double)TS;
            fs_ab i = to_ab(I_P * cexp(I * (W_H * t - FS_TEST_PI / 2)) + 3.0 * cexp(I * W_F * t));
            float th = (float)fs_test_wrap(W_H * t);
            fs_hfi_filter_step(&a, i, th, 0.1f, &i_f, &i_hn);
            if (k % 2) {
                fs_hfi_filter_step(&b, i, th, 0.1f, &j_f, NULL);  /* i_hn not wanted */
                worst = fmax(worst, hypot(i_f.alpha - j_f.alpha, i_f.beta - j_f.beta));
            } else {
                fs_hfi_filter_step(&b, i, th, 0.1f, NULL, NULL);  /* nothing wanted: the state still moves */
            }
        }
        FS_CHECK(worst == 0.0, "NULL outputs changed the filter: %.3g", worst);
        fs_hfi_filter_reset(&a);
        FS_CHECK(a.srff_p.lp.d == 0.0f && a.srff_p.lp.q == 0.0f && a.srff_n.lp.d == 0.0f && a.srff_n.lp.q == 0.0f,
                 "reset clears both SRFFs");
        fs_ab i = {4.0f, -7.0f};
        fs_hfi_filter_step(&a, i, 2.0f, -1.0f, &i_f, &i_hn);
        /* the first outputs: g_p g_n i and g_p (1 - g_n) i (fs_srff.h) */
        const double gp = a.srff_p.g, gn = a.srff_n.g;
        FS_CHECK(fabs(i_f.alpha - gp * gn * 4.0) < 1e-5 && fabs(i_f.beta + gp * gn * 7.0) < 1e-5,
                 "after reset: i_f = g_p g_n i (%g, %g)", i_f.alpha, i_f.beta);
        FS_CHECK(fabs(i_hn.alpha - gp * (1.0 - gn) * 4.0) < 1e-5 && fabs(i_hn.beta + gp * (1.0 - gn) * 7.0) < 1e-5,
                 "after reset: i_hn = g_p (1 - g_n) i (%g, %g)", i_hn.alpha, i_hn.beta);
    }
    return fs_test_summary("test_hfi_filter");
}
