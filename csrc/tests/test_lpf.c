/* fs-test-sources: control/fs_lpf.c control/fs_status.c
 *
 * The adaptive low-pass filter of the SMO (yang2022 Fig. 1): at its cutoff it
 * lags by pi/4 and halves the power, whatever the cutoff; the floor holds at
 * zero speed.
 */
#include <math.h>

#include "control/fs_lpf.h"
#include "fs_test.h"

/* Steady response of the filter to a rotating unit vector at w, cutoff w_c:
 * returns the phase lag and the gain. */
static void response(float Ts, float w, float w_c, double *lag, double *gain)
{
    fs_lpf f;
    fs_lpf_config c = {Ts, 1.0f};
    FS_CHECK(fs_lpf_init(&f, &c) == FS_OK, "init");
    int n = (int)(40.0 / (w_c * Ts)) + 2000;
    fs_ab y = {0.0f, 0.0f};
    double th = 0.0;
    for (int k = 0; k < n; ++k) {
        th = w * Ts * k;
        fs_ab x = {(float)cos(th), (float)sin(th)};
        y = fs_lpf_step(&f, x, w_c);
    }
    double ang = atan2(y.beta, y.alpha);
    double d = remainder(th - ang, 2 * FS_TEST_PI);
    *lag = d;
    *gain = hypot(y.alpha, y.beta);
}

int main(void)
{
    const float Ts = 1e-4f;
    float cutoffs[] = {50.0f, 200.0f, 500.0f, 1000.0f};
    for (int k = 0; k < 4; ++k) {
        double lag, gain;
        response(Ts, cutoffs[k], cutoffs[k], &lag, &gain);
        /* backward Euler adds about w Ts / 2 of lag to the continuous pi/4 */
        FS_CHECK_NEAR(lag, FS_TEST_PI / 4, 0.6 * cutoffs[k] * Ts + 1e-3, "lag at cutoff");
        FS_CHECK_NEAR(gain, 1.0 / sqrt(2.0), 0.02, "gain at cutoff");
        /* the lag is that of the cutoff, not a constant: a decade above it lags more */
        response(Ts, 5.0f * cutoffs[k] > 3000.0f ? 3000.0f : 5.0f * cutoffs[k], cutoffs[k], &lag, &gain);
        FS_CHECK(lag > FS_TEST_PI / 4 + 0.3, "lag above cutoff %g", lag);
    }
    /* negative speed: same lag in the sense of rotation */
    double lag, gain;
    response(Ts, -300.0f, -300.0f, &lag, &gain);
    FS_CHECK_NEAR(lag, -FS_TEST_PI / 4, 0.6 * 300.0f * Ts + 1e-3, "lag at negative cutoff");
    /* floor: a zero cutoff still filters (no division by zero, finite output) */
    fs_lpf f;
    fs_lpf_config c = {Ts, 10.0f};
    fs_lpf_init(&f, &c);
    fs_ab x = {1.0f, 0.0f};
    fs_ab y = {0.0f, 0.0f};
    for (int k = 0; k < 100; ++k) y = fs_lpf_step(&f, x, 0.0f);
    FS_CHECK(isfinite(y.alpha) && y.alpha > 0.0f && y.alpha < 0.2f, "floor cutoff output %g", y.alpha);
    FS_CHECK(fs_lpf_init(&f, &(fs_lpf_config){Ts, 0.0f}) == FS_ERR_BANDWIDTH, "zero floor refused");
    return fs_test_summary("test_lpf");
}
