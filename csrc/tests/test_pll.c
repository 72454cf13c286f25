/* fs-test-sources: control/fs_pll.c control/fs_status.c
 *
 * fs_pll: gains and init validation; zero steady-state error on a constant-
 * speed ramp angle (type-2 loop), both directions and across the +-pi wrap;
 * the angle-step response against the continuous model
 *   G(s) = (K_p s + K_i) / (s^2 + K_p s + K_i),  K_p = 2 w_b, K_i = w_b^2,
 * whose step response is 1 - exp(-w_b t) (1 - w_b t): overshoot exp(-2)
 * at t = 2/w_b; the speed clamp.
 */
#include "control/fs_math.h"
#include "control/fs_pll.h"
#include "tests/fs_test.h"

static void ramp(float w0, float bw, float Ts)
{
    fs_pll pll;
    fs_pll_config c = {Ts, bw, 0.0f};
    FS_CHECK(fs_pll_init(&pll, &c) == FS_OK, "init");
    const int n = (int)(2.0 / Ts);
    double max_err_tail = 0.0, max_w_err_tail = 0.0;
    int wraps = 0;
    float prev = pll.theta;
    for (int k = 0; k < n; ++k) {
        double theta_true = fs_test_wrap((double)w0 * Ts * k + 0.3);
        float err = (float)fs_test_wrap(theta_true - pll.theta);
        float th = fs_pll_step(&pll, err);
        FS_CHECK(th > -FS_PI && th <= FS_PI, "estimate %.9g outside (-pi, pi]", th);
        if (fabsf(th - prev) > FS_PI) ++wraps;
        prev = th;
        if (k > n / 2) {  /* after > 100 time constants */
            if (fabs(err) > max_err_tail) max_err_tail = fabs(err);
            if (fabs(pll.w - w0) > max_w_err_tail) max_w_err_tail = fabs(pll.w - w0);
        }
    }
    /* Zero steady error: only float rounding of the angle (ulp(pi) = 2.4e-7). */
    FS_CHECK(max_err_tail < 2e-5, "ramp w0 = %g: steady angle error %.3g", w0, max_err_tail);
    FS_CHECK(max_w_err_tail < 1e-3 * fabsf(w0) + 1e-2, "ramp w0 = %g: steady speed error %.3g", w0, max_w_err_tail);
    if (fabsf(w0) > 100.0f) FS_CHECK(wraps > 10, "the ramp should have crossed +-pi (%d)", wraps);
}

int main(void)
{
    fs_pll pll;
    fs_pll_config c = {1e-4f, 200.0f, 0.0f};
    FS_CHECK_EQ_INT(fs_pll_init(&pll, &c), FS_OK, "init");
    FS_CHECK_NEAR(pll.k_p, 400.0, 1e-4, "K_p = 2 w_b");
    FS_CHECK_NEAR(pll.k_i, 40000.0, 1e-2, "K_i = w_b^2");
    FS_CHECK(pll.theta == 0.0f && pll.w == 0.0f && pll.integ == 0.0f, "init state");
    FS_CHECK_EQ_INT(fs_pll_init(NULL, &c), FS_ERR_NULL, "null");
    FS_CHECK_EQ_INT(fs_pll_init(&pll, NULL), FS_ERR_NULL, "null cfg");
    fs_pll_config bad = c;
    bad.Ts = 0.0f;
    FS_CHECK_EQ_INT(fs_pll_init(&pll, &bad), FS_ERR_TS, "Ts = 0");
    bad = c;
    bad.bandwidth = 0.0f;
    FS_CHECK_EQ_INT(fs_pll_init(&pll, &bad), FS_ERR_BANDWIDTH, "bandwidth = 0");
    bad.bandwidth = -5.0f;
    FS_CHECK_EQ_INT(fs_pll_init(&pll, &bad), FS_ERR_BANDWIDTH, "bandwidth < 0");
    bad.bandwidth = 1e5f;
    FS_CHECK_EQ_INT(fs_pll_init(&pll, &bad), FS_ERR_BANDWIDTH, "bandwidth above Nyquist");

    /* reset wraps the angle and sets the speed. */
    fs_pll_reset(&pll, 4.0f, 123.0f);
    FS_CHECK_NEAR(pll.theta, 4.0 - 2.0 * FS_TEST_PI, 1e-6, "reset wraps");
    FS_CHECK(pll.w == 123.0f, "reset speed");
    /* With zero error it free-runs at that speed. */
    float th0 = pll.theta;
    fs_pll_step(&pll, 0.0f);
    FS_CHECK_NEAR(pll.theta, th0 + 123.0 * 1e-4, 1e-6, "free run");
    FS_CHECK_NEAR(pll.w, 123.0, 1e-4, "free run speed");

    /* Ramps. */
    ramp(300.0f, 200.0f, 1e-4f);
    ramp(-300.0f, 200.0f, 1e-4f);
    ramp(2000.0f, 500.0f, 1e-4f);
    ramp(5.0f, 50.0f, 1e-4f);
    ramp(0.0f, 200.0f, 1e-4f);

    /* Angle step: reset at 0, true angle 0.1 rad (small: sin(e) = e). */
    const float Ts = 1e-4f, wb = 200.0f;
    c.Ts = Ts;
    c.bandwidth = wb;
    fs_pll_init(&pll, &c);
    const double step = 0.1;
    double peak = 0.0, t_peak = 0.0, max_dev = 0.0;
    for (int k = 1; k <= 2000; ++k) {  /* 20 time constants */
        float err = (float)(step - pll.theta);
        fs_pll_step(&pll, sinf(err));
        double t = k * (double)Ts;
        double y = pll.theta / step;
        double y_c = 1.0 - exp(-wb * t) * (1.0 - wb * t);
        if (y - 1.0 > peak) { peak = y - 1.0; t_peak = t; }
        if (fabs(y - y_c) > max_dev) max_dev = fabs(y - y_c);
    }
    const double os_c = exp(-2.0);  /* 0.1353 at t = 2/w_b */
    printf("PLL step: overshoot %.4f at %.4g s (continuous %.4f at %.4g s), max deviation %.4f\n",
           peak, t_peak, os_c, 2.0 / wb, max_dev);
    FS_CHECK(peak <= os_c * 1.05, "overshoot %.4f beyond the continuous model's %.4f", peak, os_c);
    FS_CHECK(peak >= os_c * 0.90, "overshoot %.4f much below the model's %.4f: not the designed poles", peak, os_c);
    FS_CHECK_NEAR(t_peak, 2.0 / wb, 0.1 * 2.0 / wb, "time of the peak");
    FS_CHECK(max_dev < 0.03, "step response deviates from the continuous model by %.4f", max_dev);
    FS_CHECK_NEAR(pll.theta, step, 1e-5, "settled");

    /* Speed clamp: a huge constant error cannot push the speed past w_max. */
    c.w_max = 100.0f;
    fs_pll_init(&pll, &c);
    for (int k = 0; k < 10000; ++k) fs_pll_step(&pll, 1.0f);
    FS_CHECK(fabsf(pll.integ) <= 100.0f, "integral %.6g beyond w_max", pll.integ);
    FS_CHECK(fabsf(pll.w) <= 100.0f, "speed %.6g beyond w_max", pll.w);
    for (int k = 0; k < 10000; ++k) fs_pll_step(&pll, -1.0f);
    FS_CHECK(pll.integ >= -100.0f && pll.w >= -100.0f, "negative clamp %.6g", pll.w);
    return fs_test_summary("test_pll");
}
