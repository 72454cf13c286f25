/* fs-test-sources:
 *
 * fs_math.h: fs_wrap_pi on the inputs a control loop really produces
 * (|x| up to 1000 rad, exactly +-pi, multiples of pi), and its modulo-2pi
 * equality for large inputs; fs_clampf, fs_signf; fs_clamp_sym and
 * fs_clamp01 as fs_clampf(x, -L, L) and fs_clampf(x, 0, 1) bit for bit,
 * the special values included.
 * The output range for large inputs is in test_math_wrap_range.c.
 */
#include <float.h>
#include <stdint.h>
#include <string.h>

#include "control/fs_math.h"
#include "tests/fs_test.h"

/* Distance of (x - y) from the nearest multiple of the true 2 pi. */
static double mod_2pi_residual(float x, float y)
{
    const double two_pi = 2.0 * FS_TEST_PI;
    double r = fmod((double)x - (double)y, two_pi);
    if (r > FS_TEST_PI) r -= two_pi;
    if (r < -FS_TEST_PI) r += two_pi;
    return fabs(r);
}

/* Allowed residual: the float period FS_TWO_PI differs from 2 pi by 1.7e-7
 * and x - n FS_TWO_PI rounds at the scale of x: a few ulp of |x|. */
static double mod_tol(float x) { return 4.0 * FLT_EPSILON * fabs((double)x) + 1e-6; }

static void check_in_range_and_mod(float x)
{
    float y = fs_wrap_pi(x);
    FS_CHECK(y > -FS_PI && y <= FS_PI, "wrap(%.9g) = %.9g outside (-pi, pi]", x, y);
    FS_CHECK(mod_2pi_residual(x, y) <= mod_tol(x), "wrap(%.9g) = %.9g differs from x mod 2pi by %.3g",
             x, y, mod_2pi_residual(x, y));
}

int main(void)
{
    /* Already in range: returned unchanged (bit for bit). */
    const float inside[] = {0.0f, -0.0f, 1.0f, -1.0f, 3.0f, -3.0f, 3.1415f, -3.1415f, 1e-30f, -1e-30f, FS_PI};
    for (size_t k = 0; k < sizeof inside / sizeof inside[0]; ++k) {
        float y = fs_wrap_pi(inside[k]);
        FS_CHECK(memcmp(&y, &inside[k], sizeof y) == 0, "wrap(%.9g) = %.9g changed an in-range value",
                 inside[k], y);
    }

    /* Exactly pi and -pi (the float nearest pi): both give +pi. */
    FS_CHECK(fs_wrap_pi(FS_PI) == FS_PI, "wrap(pi) = %.9g", fs_wrap_pi(FS_PI));
    FS_CHECK(fs_wrap_pi(-FS_PI) == FS_PI, "wrap(-pi) = %.9g", fs_wrap_pi(-FS_PI));
    FS_CHECK(fs_wrap_pi((float)FS_TEST_PI) == FS_PI, "wrap((float)M_PI)");
    FS_CHECK(fs_wrap_pi(-(float)FS_TEST_PI) == FS_PI, "wrap(-(float)M_PI)");
    /* Just beyond the ends. */
    float above = nextafterf(FS_PI, 10.0f), below = nextafterf(-FS_PI, -10.0f);
    check_in_range_and_mod(above);
    check_in_range_and_mod(below);
    FS_CHECK(fs_wrap_pi(above) < -3.14159f, "wrap(pi+) = %.9g should be near -pi", fs_wrap_pi(above));
    FS_CHECK(fs_wrap_pi(below) > 3.14159f, "wrap(-pi-) = %.9g should be near +pi", fs_wrap_pi(below));
    float just_below = nextafterf(-FS_PI, 0.0f);
    FS_CHECK(fs_wrap_pi(just_below) == just_below, "wrap(-pi + ulp) changed");

    /* Odd multiples of pi land on +-pi (within rounding), even ones on 0. */
    for (int n = -51; n <= 51; ++n) {
        float x = (float)n * FS_PI;
        float y = fs_wrap_pi(x);
        check_in_range_and_mod(x);
        if (n % 2 != 0) {
            FS_CHECK(fabsf(fabsf(y) - FS_PI) <= 4e-5f, "wrap(%d pi) = %.9g, want +-pi", n, y);
        } else {
            FS_CHECK(fabsf(y) <= 4e-5f, "wrap(%d pi) = %.9g, want 0", n, y);
        }
    }

    /* Dense sweep of |x| <= 1000: in range, equal modulo 2 pi, idempotent. */
    for (long k = -2000000; k <= 2000000; ++k) {
        float x = (float)k * 5e-4f + 1.234567e-5f;
        float y = fs_wrap_pi(x);
        check_in_range_and_mod(x);
        FS_CHECK(fs_wrap_pi(y) == y, "wrap not idempotent at %.9g", x);
    }
    /* Every float bit pattern (with a stride) with |x| <= 1000. */
    for (uint32_t bits = 0; bits < 0x7f800000u; bits += 997) {
        float x;
        memcpy(&x, &bits, sizeof x);
        if (x > 1000.0f) break;
        check_in_range_and_mod(x);
        check_in_range_and_mod(-x);
    }

    /* Large inputs: still equal modulo 2 pi, up to the float resolution of x. */
    const float large[] = {1e4f, -1e4f, 12345.678f, 1e5f, -98765.4f, 1e6f, -1e6f, 4.2e6f, 1e7f, -1e7f};
    for (size_t k = 0; k < sizeof large / sizeof large[0]; ++k) {
        float y = fs_wrap_pi(large[k]);
        FS_CHECK(mod_2pi_residual(large[k], y) <= mod_tol(large[k]), "wrap(%.9g) = %.9g: residual %.3g",
                 large[k], y, mod_2pi_residual(large[k], y));
        FS_CHECK(fabsf(y) <= FS_PI + 1e-3f, "wrap(%.9g) = %.9g far outside (-pi, pi]", large[k], y);
    }

    /* fs_clampf, fs_signf. */
    FS_CHECK(fs_clampf(2.0f, -1.0f, 1.0f) == 1.0f, "clamp high");
    FS_CHECK(fs_clampf(-2.0f, -1.0f, 1.0f) == -1.0f, "clamp low");
    FS_CHECK(fs_clampf(0.25f, -1.0f, 1.0f) == 0.25f, "clamp inside");

    /* fs_clamp_sym(x, L) is fs_clampf(x, -L, L) for every pair, the ends,
     * zeros of both signs, infinities, NaN and a negative L included */
    const float vals[] = {0.0f, -0.0f, 1e-45f, -1e-45f, 0.25f, -0.25f, 1.0f, -1.0f, nextafterf(1.0f, 2.0f),
                          -nextafterf(1.0f, 2.0f), 2.0f, -2.0f, 1e18f, -1e18f, 3e38f, -3e38f,
                          INFINITY, -INFINITY, NAN, -NAN};
    const size_t n_vals = sizeof vals / sizeof vals[0];
    int differ = 0;
    for (size_t i = 0; i < n_vals; ++i) {
        for (size_t j = 0; j < n_vals; ++j) {
            const float a = fs_clamp_sym(vals[i], vals[j]), b = fs_clampf(vals[i], -vals[j], vals[j]);
            differ += memcmp(&a, &b, sizeof a) != 0;
        }
    }
    FS_CHECK(differ == 0, "fs_clamp_sym differs from fs_clampf(x, -L, L) on %d of %zu pairs", differ, n_vals * n_vals);
    /* fs_clamp01(x) is fs_clampf(x, 0, 1) for those and for every float
     * around the ends (a stride through all others) */
    differ = 0;
    for (uint64_t u = 0; u <= 0xffffffffu; u += (u < 0x1000u || (u > 0x3f7ff000u && u < 0x3f801000u)
                                                 || (u > 0x7f7ff000u && u < 0x80001000u) ? 1u : 4099u)) {
        const uint32_t bits = (uint32_t)u;
        float x, a, b;
        memcpy(&x, &bits, sizeof x);
        a = fs_clamp01(x);
        b = fs_clampf(x, 0.0f, 1.0f);
        differ += memcmp(&a, &b, sizeof a) != 0;
    }
    for (size_t i = 0; i < n_vals; ++i) {
        const float a = fs_clamp01(vals[i]), b = fs_clampf(vals[i], 0.0f, 1.0f);
        differ += memcmp(&a, &b, sizeof a) != 0;
    }
    FS_CHECK(differ == 0, "fs_clamp01 differs from fs_clampf(x, 0, 1) on %d arguments", differ);
    FS_CHECK(fs_signf(3.0f) == 1.0f && fs_signf(-0.1f) == -1.0f && fs_signf(0.0f) == 0.0f, "sign");
    return fs_test_summary("test_math");
}
