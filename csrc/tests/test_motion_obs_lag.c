/* fs-test-sources: control/fs_motion_obs.c control/fs_hfi_filter.c control/fs_srff.c control/fs_transforms.c control/fs_status.c
 *
 * fs_motion_obs with the error read through the injection's filter (lag 1:
 * the SRFF's low-pass; lag 2: that twice, with the leak's removal). What
 * could be wrong: the filter model (the recursions of the header) not being
 * what fs_hfi_filter does; gains that do not put the poles where the header
 * says (checked on fs_motion_obs_step itself, with the filter in the loop);
 * the relative states (r1, r2) updated wrongly (the probe then shows other
 * poles); the load-ramp error not the continuous design's; and the point of
 * it all: the plain observer at the same bandwidth through the same filter
 * is unstable. Also init's refusals and fs_motion_obs_predict.
 */
#include <complex.h>
#include <string.h>

#include "control/fs_hfi_filter.h"
#include "control/fs_math.h"
#include "control/fs_motion_obs.h"
#include "tests/fs_test.h"

#define J0 1.87e-3f
#define P0 5

static fs_motion_obs_config cfg0(float Ts, float w_o)
{
    fs_motion_obs_config c = {Ts, J0, 0.0f, P0, w_o};
    return c;
}

/* The filter of the header, in double: one step with x = theta - theta_het;
 * returns eps (lag 0: x itself). */
typedef struct { double a, b, lp1, lp2; int lag; } filt;

static double filt_step(filt *f, double x)
{
    const double a = f->a, b = f->b, h = 1.0 - 0.5 * b;
    if (f->lag == 0) return x;
    if (f->lag == 1) {
        const double eps = 0.5 * b * x + h * f->lp1;
        f->lp1 = a * f->lp1 + b * x;
        return eps;
    }
    const double eps = 0.25 * b * b * x + h * (1.0 + 0.5 * b) * f->lp1 - h * f->lp2;
    const double lp1 = f->lp1;
    f->lp1 = a * lp1 + b * x;
    f->lp2 = a * f->lp2 + b * h * (x - lp1);
    return eps;
}

static filt filt_make(int lag, double w_lag, double Ts)
{
    filt f = {exp(-w_lag * Ts), 1.0 - exp(-w_lag * Ts), 0.0, 0.0, lag};
    return f;
}

static void check_init(void)
{
    fs_motion_obs o;
    const float Ts = 1e-4f;
    const fs_motion_obs_config c = cfg0(Ts, 100.0f);
    FS_CHECK_EQ_INT(fs_motion_obs_init_lag(&o, &c, 1, 300.0f), FS_OK, "lag 1");
    FS_CHECK(o.lag == 1 && o.w_lag == 300.0f && o.r1 == 0.0f && o.r2 == 0.0f, "init: the filter, its images at the estimate");
    FS_CHECK_EQ_INT(fs_motion_obs_init_lag(&o, &c, 2, 300.0f), FS_OK, "lag 2");
    FS_CHECK_EQ_INT(fs_motion_obs_init_lag(&o, &c, 3, 300.0f), FS_ERR_PARAM, "lag 3");
    FS_CHECK_EQ_INT(fs_motion_obs_init_lag(&o, &c, -1, 300.0f), FS_ERR_PARAM, "lag -1");
    FS_CHECK_EQ_INT(fs_motion_obs_init_lag(NULL, &c, 1, 300.0f), FS_ERR_NULL, "NULL");
    const float bad[] = {0.0f, -1.0f, NAN, INFINITY, 0.51f / Ts};
    for (int i = 0; i < 5; ++i)
        FS_CHECK(fs_motion_obs_init_lag(&o, &c, 1, bad[i]) == FS_ERR_BANDWIDTH, "w_lag = %g accepted", (double)bad[i]);
    FS_CHECK_EQ_INT(fs_motion_obs_init_lag(&o, &c, 2, 0.5f / Ts), FS_OK, "w_lag Ts = 0.5 is allowed");
    FS_CHECK_EQ_INT(fs_motion_obs_init_lag(&o, &c, 0, NAN), FS_OK, "lag 0 takes no w_lag");
    FS_CHECK(o.lag == 0 && o.w_lag == 0.0f, "lag 0: none");
    fs_motion_obs p;
    fs_motion_obs_init(&p, &c);
    FS_CHECK(!memcmp(&p, &o, sizeof o), "fs_motion_obs_init is lag 0");
}

/* The recursions are fs_hfi_filter's: at standstill (theta_hat = 0) a
 * negative carrier e^{j(-theta_h + 2 theta_r)} whose rotor angle steps by
 * 0.01 rad; eq. (26)'s error, arg(i_hn e^{-j theta_n}) / 2 less its value
 * before the step, follows the lag-1 recursion with the paper's filter
 * (step_cs) and the lag-2 one with the leak's removal (step_nl). What is left
 * is H_p's passage at 2 w_h (about w_b / (2 w_h) of the step's transient). */
static void check_filter_model(void)
{
    const double Ts = 1.25e-4, w_h = 2.0 * FS_TEST_PI * 1000.0, w_b = w_h / 20.0, dth = 0.01;
    for (int lag = 1; lag <= 2; ++lag) {
        fs_hfi_filter f;
        fs_hfi_filter_config fc = {(float)Ts, (float)w_b, (float)w_b};
        FS_CHECK_EQ_INT(fs_hfi_filter_init(&f, &fc), FS_OK, "filter init");
        filt m = filt_make(lag, w_b, Ts);
        const int k0 = 400, n = 800;
        double e0 = 0.0, worst = 0.0, at_20 = 0.0;
        for (int k = 0; k < n; ++k) {
            const double th_h = fs_test_wrap(w_h * Ts * k), th_r = k >= k0 ? dth : 0.0;
            const double complex z = cexp(I * (-th_h + 2.0 * th_r));
            const fs_ab i = {(float)creal(z), (float)cimag(z)};
            const fs_ab e_h = {(float)cos(th_h), (float)sin(th_h)}, e_n = {(float)cos(-th_h), (float)sin(-th_h)};
            fs_ab i_f, i_hn;
            if (lag == 1) fs_hfi_filter_step_cs(&f, i, e_h, e_n, &i_f, &i_hn);
            else fs_hfi_filter_step_nl(&f, i, e_h, e_n, &i_f, &i_hn);
            const double eps = 0.5 * carg((i_hn.alpha + I * i_hn.beta) * cexp(I * th_h));
            if (k == k0 - 1) e0 = eps;
            if (k < k0) continue;
            const double y = (eps - e0) / dth, y_m = filt_step(&m, 1.0);
            worst = fmax(worst, fabs(y - y_m));
            if (k == k0 + 20) at_20 = y;
        }
        printf("filter model, lag %d: step response at 20 samples %.4f, worst deviation from the recursion %.4f\n",
               lag, at_20, worst);
        FS_CHECK(worst < 0.01, "lag %d: fs_hfi_filter is not the header's recursion (off by %.4f of the step)", lag, worst);
    }
}

/* Characteristic polynomial of an n x n matrix (n <= 7), Faddeev-LeVerrier:
 * z^n + c[n-1] z^(n-1) + ... + c[0]. */
static void charpoly_n(int n, double A[7][7], double c[8])
{
    double M[7][7] = {{0}}, AM[7][7];
    c[n] = 1.0;
    for (int k = 1; k <= n; ++k) {
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) M[i][j] = (k == 1 ? 0.0 : AM[i][j]) + (i == j ? c[n - k + 1] : 0.0);
        double tr = 0.0;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) {
                AM[i][j] = 0.0;
                for (int m = 0; m < n; ++m) AM[i][j] += A[i][m] * M[m][j];
            }
        for (int i = 0; i < n; ++i) tr += AM[i][i];
        c[n - k] = -tr / k;
    }
}

/* The poles of the implementation with the filter in the loop: the true
 * motion at rest at 0, no torque; the state is the observer's (theta_hat,
 * w_hat, the disturbance, r1 [, r2]) and the filter's (lp1 [, lp2]). One
 * step of fs_motion_obs_step on the recursion's eps maps it linearly; probes
 * give the matrix. Its eigenvalues: the error's (z_o three times, a lag
 * times) and the filter's images of theta_het (a, lag times): in q = z - 1
 * the polynomial (q + c)^3 (q + b)^(2 lag), checked on its coefficients. */
static void check_poles_from_step(float Ts, float w_o, int lag, float w_lag, float B)
{
    fs_motion_obs o;
    fs_motion_obs_config cfg = cfg0(Ts, w_o);
    cfg.B = B;
    FS_CHECK_EQ_INT(fs_motion_obs_init_lag(&o, &cfg, lag, w_lag), FS_OK, "init");
    const int n = 3 + 2 * lag, i_lp = 3 + lag;   /* [theta_hat, w_hat, acc, r1 (, r2), lp1 (, lp2)] */
    const double scale[7] = {1e-2, 1.0, 100.0, 1e-2, 1e-2, 1e-2, 1e-2};   /* rad, rad/s, rad/s^2, rad... */
    double A[7][7] = {{0}};
    for (int j = 0; j < n; ++j) {
        filt f = filt_make(lag, w_lag, Ts);
        const float u = (float)scale[j];
        fs_motion_obs_reset(&o, j == 0 ? u : 0.0f, j == 1 ? u : 0.0f);
        o.T_d_hat = j == 2 ? u / o.k_u : 0.0f;
        o.r1 = j == 3 ? u : 0.0f;
        o.r2 = (lag == 2 && j == 4) ? u : 0.0f;
        f.lp1 = j == i_lp ? u : 0.0;
        f.lp2 = (lag == 2 && j == i_lp + 1) ? u : 0.0;
        const double eps = filt_step(&f, -(double)o.theta_hat);   /* the truth at 0, theta_het = theta_hat */
        fs_motion_obs_step(&o, (float)eps, 0.0f);
        double x[7] = {o.theta_hat, o.w_hat, o.T_d_hat * o.k_u, o.r1, o.r2, 0.0, 0.0};
        x[i_lp] = f.lp1;
        if (lag == 2) x[i_lp + 1] = f.lp2;
        for (int i = 0; i < n; ++i) A[i][j] = x[i] / scale[i] * scale[j] / u;
    }
    /* in q = z - 1 */
    for (int i = 0; i < n; ++i) A[i][i] -= 1.0;
    double cp[8], want[8] = {0};
    charpoly_n(n, A, cp);
    const double c = -expm1(-(double)w_o * Ts), b = -expm1(-(double)w_lag * Ts);
    /* (q + c)^3 (q + b)^(2 lag) */
    want[0] = 1.0;
    int deg = 0;
    for (int k = 0; k < n; ++k) {
        const double r = k < 3 ? c : b;
        for (int i = deg + 1; i >= 1; --i) want[i] = want[i] * r + want[i - 1];
        want[0] *= r;
        ++deg;
    }
    /* want[] holds the coefficients low to high after the loop above (want[deg] = 1) */
    double worst = 0.0;
    for (int i = 0; i < n; ++i) worst = fmax(worst, fabs(cp[i] - want[i]) / fabs(want[i]));
    /* a 1 % error of w_o moves the q^(n-1) coefficient (3c + 2 lag b) by 0.03 c */
    printf("poles from step (lag %d, w_o Ts %.3g, w_lag Ts %.3g, B %g): worst relative coefficient error %.1e "
           "(1 %% on w_o: %.1e on the first)\n", lag, (double)(w_o * Ts), (double)(w_lag * Ts), (double)B, worst,
           0.03 * c / want[n - 1]);
    FS_CHECK(worst < 1e-4, "lag %d: the poles are not (q + c)^3 (q + b)^%d (coefficient off by %.1e)", lag, 2 * lag, worst);
}

/* A torque ramp missing from T_ff (constant jerk j of the electrical angle),
 * the error read through the filter: the steady error against the header's
 * (continuous design) j (1 + 3 r) / w_o^3 and j (1 + 6 r + 3 r^2) / w_o^3,
 * r = w_o / w_lag; and the plain observer (lag 0 in its design) through the
 * same filter at the same bandwidth: unstable (it rings up and slips). */
static double ramp_error(float Ts, float w_o, int lag_design, int lag_filter, float w_lag, double jerk, double *peak)
{
    fs_motion_obs o;
    const fs_motion_obs_config cfg = cfg0(Ts, w_o);
    fs_motion_obs_init_lag(&o, &cfg, lag_design, w_lag);
    filt f = filt_make(lag_filter, w_lag, Ts);
    double th = 0.0, w = 0.0, acc = 0.0, e = 0.0;
    *peak = 0.0;
    const int n = (int)(40.0 / (w_o * Ts));
    for (int k = 0; k < n; ++k) {
        const double eps = filt_step(&f, fs_test_wrap(th - o.theta_hat));
        fs_motion_obs_step(&o, (float)eps, 0.0f);
        e = fs_test_wrap(th - o.theta_hat);
        *peak = fmax(*peak, fabs(e));
        th = fs_test_wrap(th + w * Ts + 0.5 * acc * Ts * Ts + jerk * Ts * Ts * Ts / 6.0);
        w += acc * Ts + 0.5 * jerk * Ts * Ts;
        acc += jerk * Ts;
    }
    return e;
}

static void check_ramp(void)
{
    const float Ts = 1e-4f, w_lag = (float)(2.0 * FS_TEST_PI * 1000.0 / 20.0);
    const double jerk = 1e5;
    const float ratios[3] = {0.2f, 0.5f, 1.0f};
    for (int lag = 1; lag <= 2; ++lag)
        for (int i = 0; i < 3; ++i) {
            const float w_o = ratios[i] * w_lag;
            const double r = ratios[i], w3 = (double)w_o * w_o * w_o;
            const double want = jerk / w3 * (lag == 1 ? 1.0 + 3.0 * r : 1.0 + 6.0 * r + 3.0 * r * r);
            double peak;
            const double e = ramp_error(Ts, w_o, lag, lag, w_lag, jerk, &peak);
            printf("ramp, lag %d, w_o = %.1f w_lag: steady error %.5f rad, continuous design %.5f\n", lag, (double)r, e, want);
            FS_CHECK_REL(e, want, 0.04, 0.0, "steady error of a load ramp");
        }
    double peak_plain, peak_lag;
    ramp_error(Ts, w_lag, 2, 2, w_lag, jerk, &peak_lag);
    ramp_error(Ts, w_lag, 0, 2, w_lag, jerk, &peak_plain);
    printf("w_o = w_lag through the filter twice: peak error %.4f rad designed with it, %.4f without\n", peak_lag, peak_plain);
    FS_CHECK(peak_lag < 0.05, "the observer designed with the filter: peak %.4f rad", peak_lag);
    FS_CHECK(peak_plain > 1.0, "the plain observer through the same filter should not hold (peak %.4f rad)", peak_plain);
}

/* predict: the model alone, the filter's images back at the estimate. */
static void check_predict(void)
{
    fs_motion_obs o;
    const fs_motion_obs_config c = cfg0(1e-4f, 100.0f);
    fs_motion_obs_init_lag(&o, &c, 2, 300.0f);
    fs_motion_obs_reset(&o, 0.5f, 40.0f);
    o.T_d_hat = -0.01f; o.r1 = 0.02f; o.r2 = -0.03f;
    const float T = 0.03f;
    const double acc = o.k_u * (T + o.T_d_hat);
    const double th = 0.5 + o.f1 * 40.0 + o.f2 * acc, w = o.E * 40.0 + o.f1 * acc;
    fs_motion_obs_predict(&o, T);
    FS_CHECK_NEAR(o.theta_hat, th, 1e-6, "predict: angle");
    FS_CHECK_NEAR(o.w_hat, w, 1e-5, "predict: speed");
    FS_CHECK(o.T_d_hat == -0.01f && o.r1 == 0.0f && o.r2 == 0.0f, "predict: disturbance kept, images at the estimate");
}

int main(void)
{
    check_init();
    check_filter_model();
    const float w_lag = (float)(2.0 * FS_TEST_PI * 1000.0 / 20.0);
    for (int lag = 1; lag <= 2; ++lag) {
        check_poles_from_step(1e-4f, w_lag, lag, w_lag, 0.0f);
        check_poles_from_step(1e-4f, 0.2f * w_lag, lag, w_lag, 0.0f);
        check_poles_from_step(1.25e-4f, 0.8f * 1005.3f, lag, 1005.3f, 0.05f);   /* B Ts / J = 3.3e-3 */
    }
    check_ramp();
    check_predict();
    return fs_test_summary("test_motion_obs_lag");
}
