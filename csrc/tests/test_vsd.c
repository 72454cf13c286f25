/* fs-test-sources: control/fs_vsd.c
 *
 * fs_vsd5 (five-phase VSD, amplitude-invariant): the forward transform agrees
 * with the defining sums evaluated in double (checks the constant tables);
 * forward then inverse returns the phases and inverse then forward returns
 * (ab, xy, zero), over deterministic pseudo-random inputs of many scales;
 * Parseval: sum x_k^2 = 5/2 (|ab|^2 + |xy|^2) + 5 zero^2; a balanced set
 * A cos(theta - k g) + c maps to ab = A (cos theta, sin theta), xy = 0,
 * zero = c; a third-harmonic set A cos(3 (theta - k g)) maps to
 * xy = A (cos 3theta, sin 3theta), ab = 0, zero = 0.
 */
#include <stdint.h>

#include "control/fs_vsd.h"
#include "tests/fs_test.h"

static const double G = 2.0 * FS_TEST_PI / 5.0;

/* Deterministic xorshift32: a float in [-1, 1). */
static float rnd(uint32_t *s)
{
    *s ^= *s << 13;
    *s ^= *s >> 17;
    *s ^= *s << 5;
    return (float)((double)(*s >> 8) / 8388608.0 - 1.0);
}

static double maxabs5(const float x[5])
{
    double m = 0.0;
    for (int k = 0; k < 5; ++k) m = fmax(m, fabs((double)x[k]));
    return m;
}

static void check_forward_double(const float x[5], fs_vsd5 v, double tol)
{
    double a = 0, b = 0, xx = 0, yy = 0, z = 0;
    for (int k = 0; k < 5; ++k) {
        a += 0.4 * x[k] * cos(k * G);
        b += 0.4 * x[k] * sin(k * G);
        xx += 0.4 * x[k] * cos(3.0 * k * G);
        yy += 0.4 * x[k] * sin(3.0 * k * G);
        z += 0.2 * x[k];
    }
    FS_CHECK_NEAR(v.ab.alpha, a, tol, "forward alpha vs double sums");
    FS_CHECK_NEAR(v.ab.beta, b, tol, "forward beta vs double sums");
    FS_CHECK_NEAR(v.xy.alpha, xx, tol, "forward x vs double sums");
    FS_CHECK_NEAR(v.xy.beta, yy, tol, "forward y vs double sums");
    FS_CHECK_NEAR(v.zero, z, tol, "forward zero vs double sums");
}

int main(void)
{
    const float scales[] = {1e-3f, 1.0f, 48.0f, 600.0f, 1e5f};
    uint32_t s = 0x12345678u;
    for (int si = 0; si < 5; ++si) {
        for (int n = 0; n < 2000; ++n) {
            /* phases -> planes -> phases */
            float x[5], back[5];
            for (int k = 0; k < 5; ++k) x[k] = scales[si] * rnd(&s);
            double m = maxabs5(x), tol = 1e-6 * m;
            fs_vsd5 v = fs_vsd5_forward(x);
            check_forward_double(x, v, tol);
            fs_vsd5_inverse(&v, back);
            for (int k = 0; k < 5; ++k) FS_CHECK_NEAR(back[k], x[k], tol, "forward then inverse");
            double e_ph = 0.0;
            for (int k = 0; k < 5; ++k) e_ph += (double)x[k] * x[k];
            double e_pl = 2.5 * ((double)v.ab.alpha * v.ab.alpha + (double)v.ab.beta * v.ab.beta
                                 + (double)v.xy.alpha * v.xy.alpha + (double)v.xy.beta * v.xy.beta)
                          + 5.0 * (double)v.zero * v.zero;
            FS_CHECK_NEAR(e_pl, e_ph, 2e-6 * 5.0 * m * m, "Parseval");

            /* planes -> phases -> planes */
            fs_vsd5 w;
            w.ab.alpha = scales[si] * rnd(&s);
            w.ab.beta = scales[si] * rnd(&s);
            w.xy.alpha = scales[si] * rnd(&s);
            w.xy.beta = scales[si] * rnd(&s);
            w.zero = scales[si] * rnd(&s);
            fs_vsd5_inverse(&w, x);
            fs_vsd5 w2 = fs_vsd5_forward(x);
            tol = 2e-6 * scales[si];
            FS_CHECK_NEAR(w2.ab.alpha, w.ab.alpha, tol, "inverse then forward: alpha");
            FS_CHECK_NEAR(w2.ab.beta, w.ab.beta, tol, "inverse then forward: beta");
            FS_CHECK_NEAR(w2.xy.alpha, w.xy.alpha, tol, "inverse then forward: x");
            FS_CHECK_NEAR(w2.xy.beta, w.xy.beta, tol, "inverse then forward: y");
            FS_CHECK_NEAR(w2.zero, w.zero, tol, "inverse then forward: zero");
        }
    }

    /* Balanced and third-harmonic sets. */
    const double amps[] = {1e-3, 0.5, 1.0, 230.0, 600.0};
    for (int ai = 0; ai < 5; ++ai) {
        double A = amps[ai], tol = 1e-6 * A;
        for (int i = 0; i < 721; ++i) {
            double th = -2.0 * FS_TEST_PI + i * 4.0 * FS_TEST_PI / 720.0 + 1e-3;
            float f1[5], f3[5];
            for (int k = 0; k < 5; ++k) {
                f1[k] = (float)(A * cos(th - k * G) + 0.25 * A);
                f3[k] = (float)(A * cos(3.0 * (th - k * G)));
            }
            fs_vsd5 v1 = fs_vsd5_forward(f1), v3 = fs_vsd5_forward(f3);
            FS_CHECK_NEAR(v1.ab.alpha, A * cos(th), tol, "balanced: alpha");
            FS_CHECK_NEAR(v1.ab.beta, A * sin(th), tol, "balanced: beta");
            FS_CHECK_NEAR(v1.xy.alpha, 0.0, tol, "balanced: x");
            FS_CHECK_NEAR(v1.xy.beta, 0.0, tol, "balanced: y");
            FS_CHECK_NEAR(v1.zero, 0.25 * A, tol, "balanced: zero sequence");
            FS_CHECK_NEAR(v3.xy.alpha, A * cos(3.0 * th), tol, "third harmonic: x");
            FS_CHECK_NEAR(v3.xy.beta, A * sin(3.0 * th), tol, "third harmonic: y");
            FS_CHECK_NEAR(v3.ab.alpha, 0.0, tol, "third harmonic: alpha");
            FS_CHECK_NEAR(v3.ab.beta, 0.0, tol, "third harmonic: beta");
            FS_CHECK_NEAR(v3.zero, 0.0, tol, "third harmonic: zero");
        }
    }
    return fs_test_summary("test_vsd");
}
