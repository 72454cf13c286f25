/* fs-test-sources: control/fs_speed_ctrl.c control/fs_pi.c control/fs_status.c
 *
 * fs_speed_ctrl: gains from fs_pi_design for J dw/dt = T - B w (for small
 * alpha Ts: k_t = alpha J, k_p = 2 alpha J - B, k_i = alpha^2 J), the torque
 * limit with anti-windup, init validation, and the sampled closed loop being
 * exactly first order: w_k = 1 - p^k, p = exp(-alpha Ts).
 */
#include "control/fs_speed_ctrl.h"
#include "tests/fs_test.h"

int main(void)
{
    fs_speed_ctrl sc;
    fs_speed_ctrl_config c = {1e-3f, 0.01f, 0.002f, 50.0f, 5.0f, 0.0f, 0.0f};
    FS_CHECK_EQ_INT(fs_speed_ctrl_init(&sc, &c), FS_OK, "init");
    {
        const double Ts = 1e-3, J = 0.01, B = 0.002, al = 50.0;
        double a = exp(-B * Ts / J), b = (1 - a) / B, p = exp(-al * Ts);
        FS_CHECK_REL(sc.pi.cfg.k_t, (1 - p) / b, 2e-5, 0, "k_t = (1-p)/b");
        FS_CHECK_REL(sc.pi.cfg.k_p, (1 + a - 2 * p) / b, 2e-5, 0, "k_p = (1+a-2p)/b");
        FS_CHECK_REL(sc.pi.cfg.k_i, (1 - p) * (1 - p) / (b * Ts), 2e-5, 0, "k_i = (1-p)^2/(b Ts)");
        /* alpha Ts = 0.05: within a few % of the continuous design */
        FS_CHECK_REL(sc.pi.cfg.k_t, al * J, 0.05, 0, "k_t ~ alpha J");
        FS_CHECK_REL(sc.pi.cfg.k_p, 2 * al * J - B, 0.06, 0, "k_p ~ 2 alpha J - B");
        FS_CHECK_REL(sc.pi.cfg.k_i, al * al * J, 0.06, 0, "k_i ~ alpha^2 J");
    }
    FS_CHECK(sc.pi.cfg.u_max == 5.0f, "torque limit");

    fs_speed_ctrl_config b = c; b.Ts = 0.0f;       FS_CHECK_EQ_INT(fs_speed_ctrl_init(&sc, &b), FS_ERR_TS, "Ts");
    b = c; b.J = 0.0f;                             FS_CHECK_EQ_INT(fs_speed_ctrl_init(&sc, &b), FS_ERR_J, "J");
    b = c; b.B = -1.0f;                            FS_CHECK_EQ_INT(fs_speed_ctrl_init(&sc, &b), FS_ERR_PARAM, "B");
    b = c; b.bandwidth = 0.0f;                     FS_CHECK_EQ_INT(fs_speed_ctrl_init(&sc, &b), FS_ERR_BANDWIDTH, "bw");
    b = c; b.bandwidth = 1000.0f;                  FS_CHECK_EQ_INT(fs_speed_ctrl_init(&sc, &b), FS_ERR_BANDWIDTH, "bw Ts");
    b = c; b.T_max = 0.0f;                         FS_CHECK_EQ_INT(fs_speed_ctrl_init(&sc, &b), FS_ERR_LIMIT, "T_max");
    FS_CHECK_EQ_INT(fs_speed_ctrl_init(NULL, &c), FS_ERR_NULL, "null");

    /* Closed loop, small step (no saturation), plant sampled exactly: w = 1 - p^k. */
    fs_speed_ctrl_init(&sc, &c);
    double w = 0.0, dev = 0.0;
    const double Ts = 1e-3, J = 0.01, B = 0.002, a = exp(-B * Ts / J);
    for (int k = 1; k <= 200; ++k) {
        float T = fs_speed_ctrl_step(&sc, 1.0f, (float)w);
        w = a * w + (1.0 - a) * T / B;
        double want = 1.0 - pow(exp(-50.0 * Ts), k);
        if (fabs(w - want) > dev) dev = fabs(w - want);
    }
    printf("speed loop: max deviation from 1 - p^k: %.2e\n", dev);
    FS_CHECK(dev < 1e-4, "closed loop deviates from 1 - p^k by %.3g", dev);

    /* Large step: torque limited, no overshoot from windup. */
    fs_speed_ctrl_reset(&sc);
    w = 0.0;
    double w_max = 0.0;
    for (int k = 1; k <= 3000; ++k) {
        float T = fs_speed_ctrl_step(&sc, 100.0f, (float)w);
        FS_CHECK(fabsf(T) <= 5.0f, "torque %g beyond the limit", T);
        w = a * w + (1.0 - a) * T / B;
        if (w > w_max) w_max = w;
    }
    FS_CHECK(w_max < 100.0 * 1.02, "windup overshoot: peak %g for a reference of 100", w_max);
    FS_CHECK_NEAR(w, 100.0, 0.1, "settles");
    /* Explicit gains (a paper's): an ordinary PI with exactly those, limited. */
    fs_speed_ctrl_config e = c; e.k_p = 0.154f; e.k_i = 2.64f;
    FS_CHECK_EQ_INT(fs_speed_ctrl_init(&sc, &e), FS_OK, "explicit gains");
    FS_CHECK(sc.pi.cfg.k_p == 0.154f && sc.pi.cfg.k_t == 0.154f && sc.pi.cfg.k_i == 2.64f, "gains as given");
    FS_CHECK(sc.pi.cfg.u_max == 5.0f, "limited to T_max");
    e.k_p = 0.0f; FS_CHECK_EQ_INT(fs_speed_ctrl_init(&sc, &e), FS_ERR_PARAM, "k_i without k_p");
    e.k_p = 0.1f; e.k_i = -1.0f; FS_CHECK_EQ_INT(fs_speed_ctrl_init(&sc, &e), FS_ERR_PARAM, "k_i < 0");
    return fs_test_summary("test_speed_ctrl");
}
