/* fs-test-sources: control/fs_pi.c control/fs_status.c
 *
 * fs_pi_design (fs_pi.h): the sampled-data gains
 *   a = exp(-R Ts/L), b = (1-a)/R (Ts/L if R = 0), p = exp(-alpha Ts),
 *   k_t = (1-p)/b, k_p = (1+a-2p)/b, k_i = (1-p)^2/(b Ts),
 * at ordinary operating points; their small-alpha-Ts limit (Harnefors'
 * k_t = alpha L, k_p = 2 alpha L - R, k_i = alpha^2 L); the closed loop on the
 * exactly sampled plant: reference step 1 - p^k, disturbance b d k p^(k-1);
 * validation of the arguments.
 */
#include "control/fs_pi.h"
#include "tests/fs_test.h"

static void reference_gains(double Ts, double L, double R, double alpha, double g[3])
{
    double a = exp(-R * Ts / L), b = R > 0 ? -expm1(-R * Ts / L) / R : Ts / L, p = exp(-alpha * Ts);
    g[0] = -expm1(-alpha * Ts) / b;
    g[1] = fmax((1 + a - 2 * p) / b, 0.0);
    g[2] = expm1(-alpha * Ts) * expm1(-alpha * Ts) / (b * Ts);
}

int main(void)
{
    fs_pi_config c;
    /* Operating points with R Ts/L and alpha Ts well above float resolution. */
    const double pts[][4] = {
        /* Ts, L, R, alpha */
        {1e-4, 2e-3, 0.5, 2000.0},
        {1e-4, 0.065e-3, 0.036, 2500.0},  /* low-inductance IPM, alpha Ts = 0.25 */
        {1e-4, 5e-3, 0.0, 1000.0},        /* R = 0 */
        {5e-5, 1e-2, 3.0, 4000.0},
        {1e-3, 0.01, 0.002, 50.0},        /* a speed loop: L = J, R = B */
        {1e-3, 1.87e-3, 0.0, 100.0},
    };
    for (size_t n = 0; n < sizeof pts / sizeof pts[0]; ++n) {
        double Ts = pts[n][0], L = pts[n][1], R = pts[n][2], al = pts[n][3], g[3];
        FS_CHECK_EQ_INT(fs_pi_design(&c, (float)Ts, (float)L, (float)R, (float)al, 7.0f), FS_OK, "design");
        reference_gains(Ts, L, R, al, g);
        FS_CHECK(c.Ts == (float)Ts && c.u_max == 7.0f, "Ts, u_max copied");
        FS_CHECK_REL(c.k_t, g[0], 1e-4, 0, "k_t");
        FS_CHECK_REL(c.k_p, g[1], 1e-4, 0, "k_p");
        FS_CHECK_REL(c.k_i, g[2], 1e-4, 0, "k_i");

        /* Closed loop on x+ = a x + b u (exact ZOH of L dx/dt = u - R x). */
        fs_pi pi;
        FS_CHECK_EQ_INT(fs_pi_init(&pi, &c), FS_OK, "init from design");
        pi.cfg.u_max = 0.0f;
        double a = exp(-R * Ts / L), b = R > 0 ? -expm1(-R * Ts / L) / R : Ts / L, p = exp(-al * Ts);
        double x = 0.0, dev = 0.0;
        for (int k = 1; k <= 300; ++k) {
            float u = fs_pi_step(&pi, 1.0f, (float)x);
            x = a * x + b * u;
            double e = fabs(x - (1.0 - pow(p, k)));
            if (e > dev) dev = e;
        }
        FS_CHECK(dev < 2e-5, "point %zu: reference step deviates from 1 - p^k by %.3g", n, dev);
        fs_pi_reset(&pi);
        x = 0.0;
        dev = 0.0;
        const double d = 2.0;
        double peak = 0.0;
        for (int k = 1; k <= 300; ++k) {
            float u = fs_pi_step(&pi, 0.0f, (float)x);
            x = a * x + b * (u + d);
            double want = b * d * k * pow(p, k - 1);
            if (fabs(x - want) > dev) dev = fabs(x - want);
            if (want > peak) peak = want;
        }
        /* 2e-4: fs_pi_design's float 1 - expf(-x) costs ~6e-8/x relative in
         * the gains (B Ts/J = 2e-4 at point 4; see test_pi_design_precision.c) */
        FS_CHECK(dev < 2e-4 * peak + 1e-9, "point %zu: disturbance response deviates from b d k p^(k-1) by %.3g",
                 n, dev);
    }

    /* Small alpha Ts and R Ts/L: Harnefors' continuous design. */
    {
        const double Ts = 1e-6, L = 2e-3, R = 0.5, al = 1000.0;
        fs_pi_design(&c, (float)Ts, (float)L, (float)R, (float)al, 0.0f);
        FS_CHECK_REL(c.k_t, al * L, 2e-3, 0, "k_t -> alpha L");
        FS_CHECK_REL(c.k_p, 2 * al * L - R, 2e-3, 0, "k_p -> 2 alpha L - R");
        FS_CHECK_REL(c.k_i, al * al * L, 2e-3, 0, "k_i -> alpha^2 L");
    }
    /* k_p is clipped at 0 when R dominates (k_p would be negative). */
    FS_CHECK_EQ_INT(fs_pi_design(&c, 1e-4f, 1e-3f, 10.0f, 100.0f, 0.0f), FS_OK, "R-dominated");
    FS_CHECK(c.k_p == 0.0f, "k_p = %g, want 0 (clipped)", c.k_p);
    FS_CHECK(c.k_t > 0.0f && c.k_i > 0.0f, "k_t, k_i positive");

    /* Validation. */
    FS_CHECK_EQ_INT(fs_pi_design(NULL, 1e-4f, 1e-3f, 0.1f, 100.0f, 0.0f), FS_ERR_NULL, "null");
    FS_CHECK_EQ_INT(fs_pi_design(&c, 0.0f, 1e-3f, 0.1f, 100.0f, 0.0f), FS_ERR_TS, "Ts = 0");
    FS_CHECK_EQ_INT(fs_pi_design(&c, -1e-4f, 1e-3f, 0.1f, 100.0f, 0.0f), FS_ERR_TS, "Ts < 0");
    FS_CHECK_EQ_INT(fs_pi_design(&c, 1e-4f, 0.0f, 0.1f, 100.0f, 0.0f), FS_ERR_PARAM, "L = 0");
    FS_CHECK_EQ_INT(fs_pi_design(&c, 1e-4f, 1e-3f, -0.1f, 100.0f, 0.0f), FS_ERR_PARAM, "R < 0");
    FS_CHECK_EQ_INT(fs_pi_design(&c, 1e-4f, 1e-3f, 0.1f, 0.0f, 0.0f), FS_ERR_BANDWIDTH, "alpha = 0");
    FS_CHECK_EQ_INT(fs_pi_design(&c, 1e-4f, 1e-3f, 0.1f, -1.0f, 0.0f), FS_ERR_BANDWIDTH, "alpha < 0");
    FS_CHECK_EQ_INT(fs_pi_design(&c, 1e-4f, 1e-3f, 0.1f, NAN, 0.0f), FS_ERR_BANDWIDTH, "alpha NaN");
    FS_CHECK_EQ_INT(fs_pi_design(&c, 1e-4f, 1e-3f, 0.1f, 3e4f, 0.0f), FS_ERR_BANDWIDTH, "alpha Ts > 2");
    return fs_test_summary("test_pi_design");
}
