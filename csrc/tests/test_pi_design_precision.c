/* fs-test-sources: control/fs_pi.c control/fs_status.c
 *
 * fs_pi_design promises a sampled loop that is exactly first order. In float,
 * 1 - expf(-x) keeps only ~6e-8/x of relative precision, so for small
 * R Ts/L (just above the 1e-6 switch to Ts/L; e.g. a speed loop with a little
 * viscous friction) and small alpha Ts the gains drift from the documented
 * formulas. Check them within 1e-4 relative over R Ts/L from 1e-7 and alpha Ts
 * from 1e-3, both up to 0.5 (against the formulas evaluated with expm1 in double).
 */
#include "control/fs_pi.h"
#include "tests/fs_test.h"

int main(void)
{
    double worst = 0.0, worst_x = 0.0, worst_y = 0.0;
    for (double x = 1e-7; x < 0.5; x *= 1.07) {          /* R Ts / L */
        for (double y = 1e-3; y < 0.5; y *= 1.5) {       /* alpha Ts */
            const float Ts = 1e-3f, L = 1e-3f;
            float R = (float)(x * L / Ts), al = (float)(y / Ts);
            fs_pi_config c;
            if (fs_pi_design(&c, Ts, L, R, al, 0.0f) != FS_OK) continue;
            double xx = (double)R * Ts / L, yy = (double)al * Ts;
            double a = exp(-xx), b = -expm1(-xx) / R, p1 = -expm1(-yy);  /* p1 = 1 - p */
            double kt = p1 / b, kp = (a - 1 + 2 * p1) / b, ki = p1 * p1 / (b * Ts);
            double e = fmax(fabs(c.k_t / kt - 1), fabs(c.k_i / ki - 1));
            if (kp > 1e-3 * kt) e = fmax(e, fabs(c.k_p / kp - 1));
            FS_CHECK(e < 1e-4, "R Ts/L = %.3g, alpha Ts = %.3g: gains off by %.3g relative", xx, yy, e);
            if (e > worst) { worst = e; worst_x = xx; worst_y = yy; }
        }
    }
    printf("worst relative gain error %.3g at R Ts/L = %.3g, alpha Ts = %.3g\n", worst, worst_x, worst_y);
    return fs_test_summary("test_pi_design_precision");
}
