/* fs-test-sources: control/fs_pi.c control/fs_status.c
 *
 * fs_pi: init validation, ordinary PI (k_t = k_p) step response by hand,
 * the 2DOF reference gain, output() leaving the state alone, and
 * back-calculation anti-windup against a PI that winds up.
 */
#include "control/fs_pi.h"
#include "tests/fs_test.h"

static fs_pi make(float Ts, float k_t, float k_p, float k_i, float u_max)
{
    fs_pi pi;
    fs_pi_config c = {Ts, k_t, k_p, k_i, u_max};
    fs_status st = fs_pi_init(&pi, &c);
    FS_CHECK(st == FS_OK, "init: %s", fs_status_str(st));
    return pi;
}

int main(void)
{
    /* init validation */
    fs_pi pi;
    fs_pi_config c = {1e-3f, 1.0f, 1.0f, 1.0f, 0.0f};
    FS_CHECK_EQ_INT(fs_pi_init(NULL, &c), FS_ERR_NULL, "null pi");
    FS_CHECK_EQ_INT(fs_pi_init(&pi, NULL), FS_ERR_NULL, "null cfg");
    c.Ts = 0.0f;
    FS_CHECK_EQ_INT(fs_pi_init(&pi, &c), FS_ERR_TS, "Ts = 0");
    c.Ts = -1e-3f;
    FS_CHECK_EQ_INT(fs_pi_init(&pi, &c), FS_ERR_TS, "Ts < 0");
    c.Ts = 1e-3f;
    c.k_p = -1.0f;
    FS_CHECK_EQ_INT(fs_pi_init(&pi, &c), FS_ERR_PARAM, "k_p < 0");
    c.k_p = 1.0f;
    c.k_i = -1.0f;
    FS_CHECK_EQ_INT(fs_pi_init(&pi, &c), FS_ERR_PARAM, "k_i < 0");
    c.k_i = 1.0f;
    c.k_t = -1.0f;
    FS_CHECK_EQ_INT(fs_pi_init(&pi, &c), FS_ERR_PARAM, "k_t < 0");
    c.k_t = 1.0f;
    FS_CHECK_EQ_INT(fs_pi_init(&pi, &c), FS_OK, "valid");
    FS_CHECK(pi.integ == 0.0f, "integral starts at 0");

    /* Ordinary PI, Ts = 1 ms, k_p = k_t = 2, k_i = 100, unlimited, error 1:
     * u[k] = k_p e + Ts k_i e k = 2 + 0.1 k. */
    pi = make(1e-3f, 2.0f, 2.0f, 100.0f, 0.0f);
    for (int k = 0; k < 20; ++k) {
        float u = fs_pi_step(&pi, 1.0f, 0.0f);
        FS_CHECK_NEAR(u, 2.0 + 0.1 * k, 1e-5, "PI step response");
    }
    /* Same error from ref 3, meas 2 (k_t = k_p: only the error matters). */
    fs_pi_reset(&pi);
    FS_CHECK(pi.integ == 0.0f, "reset");
    for (int k = 0; k < 5; ++k) {
        float u = fs_pi_step(&pi, 3.0f, 2.0f);
        FS_CHECK_NEAR(u, 2.0 + 0.1 * k, 1e-5, "PI step response, offset");
    }
    /* Error -0.5: u[k] = -1 - 0.05 k. */
    fs_pi_reset(&pi);
    for (int k = 0; k < 5; ++k) {
        float u = fs_pi_step(&pi, 0.0f, 0.5f);
        FS_CHECK_NEAR(u, -1.0 - 0.05 * k, 1e-5, "PI negative step");
    }

    /* 2DOF: u = k_t r - k_p y + I, with k_t = 1, k_p = 3, k_i = 10, Ts = 0.1:
     * r = 2, y = 1: u0 = 2 - 3 = -1; I1 = 0.1*10*1 = 1; u1 = 0; u2 = 1. */
    pi = make(0.1f, 1.0f, 3.0f, 10.0f, 0.0f);
    FS_CHECK_NEAR(fs_pi_step(&pi, 2.0f, 1.0f), -1.0, 1e-6, "2DOF u0");
    FS_CHECK_NEAR(fs_pi_step(&pi, 2.0f, 1.0f), 0.0, 1e-6, "2DOF u1");
    FS_CHECK_NEAR(fs_pi_step(&pi, 2.0f, 1.0f), 1.0, 1e-6, "2DOF u2");

    /* fs_pi_output does not change the state; update with u_real = u adds Ts k_i e. */
    pi = make(1e-3f, 2.0f, 2.0f, 100.0f, 0.0f);
    float u = fs_pi_output(&pi, 1.0f, 0.0f);
    FS_CHECK_NEAR(u, 2.0, 1e-7, "output");
    FS_CHECK(pi.integ == 0.0f, "output changed the state");
    fs_pi_update(&pi, 1.0f, 0.0f, u, u);
    FS_CHECK_NEAR(pi.integ, 0.1, 1e-7, "update without limit");
    /* Back-calculation: realised 1.5 instead of 2.1: integ = 0.1 + 0.1 + (1.5 - 2.1). */
    u = fs_pi_output(&pi, 1.0f, 0.0f);
    fs_pi_update(&pi, 1.0f, 0.0f, u, 1.5f);
    FS_CHECK_NEAR(pi.integ, 0.1 + 0.1 + (1.5 - 2.1), 1e-6, "update with limit");
    /* ... so that the next output starts from what was realised (+ Ts k_i e). */
    FS_CHECK_NEAR(fs_pi_output(&pi, 1.0f, 0.0f), 1.5 + 0.1, 1e-6, "no windup after update");

    /* Anti-windup in fs_pi_step: u_max = 1, k_p = k_t = 1, k_i = 100, Ts = 1 ms.
     * Error 2 for 1000 steps (a long saturation), then error -0.1. */
    pi = make(1e-3f, 1.0f, 1.0f, 100.0f, 1.0f);
    float Ts = 1e-3f, kp = 1.0f, ki = 100.0f, umax = 1.0f;
    float I_wind = 0.0f;  /* a PI that clamps its output but integrates on */
    for (int k = 0; k < 1000; ++k) {
        u = fs_pi_step(&pi, 2.0f, 0.0f);
        FS_CHECK(u == 1.0f, "saturated output %g at step %d", u, k);
        FS_CHECK(u <= umax && u >= -umax, "limit");
        I_wind += Ts * ki * 2.0f;
    }
    /* The integral sits where the next unlimited output is just beyond the limit. */
    FS_CHECK_NEAR(fs_pi_output(&pi, 2.0f, 0.0f), 1.0 + 0.2, 1e-4, "held at the limit");
    int left_awu = -1, left_wind = -1;
    for (int k = 0; k < 100; ++k) {
        u = fs_pi_step(&pi, -0.1f, 0.0f);
        float u_wind = kp * -0.1f + I_wind;
        u_wind = u_wind > umax ? umax : (u_wind < -umax ? -umax : u_wind);
        I_wind += Ts * ki * -0.1f;
        if (left_awu < 0 && u < umax) left_awu = k;
        if (left_wind < 0 && u_wind < umax) left_wind = k;
    }
    /* With anti-windup the output leaves saturation at the first step with
     * the changed error (the integral was held at -0.8: u = -0.1 - 0.8). */
    FS_CHECK(left_awu >= 0 && left_awu <= 1, "anti-windup PI left saturation after %d steps", left_awu);
    /* The wound-up integral (200) would keep it saturated for ~20000 steps. */
    FS_CHECK(left_wind < 0, "reference windup PI left saturation after %d steps", left_wind);
    /* The first step after the sign change: I = -0.8, u = -0.1 - 0.8 = -0.9. */
    pi = make(1e-3f, 1.0f, 1.0f, 100.0f, 1.0f);
    for (int k = 0; k < 1000; ++k) (void)fs_pi_step(&pi, 2.0f, 0.0f);
    FS_CHECK_NEAR(fs_pi_step(&pi, -0.1f, 0.0f), -0.9, 1e-4, "first output after the sign change");

    /* Symmetric limit: long negative saturation, then a positive error. */
    pi = make(1e-3f, 1.0f, 1.0f, 100.0f, 1.0f);
    for (int k = 0; k < 1000; ++k) {
        u = fs_pi_step(&pi, -5.0f, 0.0f);
        FS_CHECK(u == -1.0f, "negative saturation %g", u);
    }
    u = fs_pi_step(&pi, 0.1f, 0.0f);
    FS_CHECK(u > -1.0f, "anti-windup, negative side: %g still saturated", u);

    /* u_max <= 0: no limit. */
    pi = make(1e-3f, 1.0f, 1.0f, 100.0f, 0.0f);
    FS_CHECK_NEAR(fs_pi_step(&pi, 1000.0f, 0.0f), 1000.0, 1e-3, "unlimited");
    return fs_test_summary("test_pi");
}
