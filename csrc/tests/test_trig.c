/* fs-test-sources: control/fs_transforms.c
 *
 * fs_math.h: fs_cis (cos and sin of one angle, fs_transforms.c) against
 * the double-precision libm on every float of |x| < 8 (with a stride) and
 * on the arguments a drive gives it (uniform angles): within 1 ulp of the
 * exact values, correctly rounded on most; zero, NaN, infinities and large
 * arguments; fs_tanf; fs_atan2f on vectors of every direction and of
 * magnitudes from 1e-30 to 1e38 (within 1.6 ulp), and on the special
 * values as C99 Annex F has atan2; fs_cis_small as fs_cis bit for bit; fs_maxf and fs_minf as fmaxf and fminf
 * are specified (NaN ignored); fs_wrap_far against the fmodf path it
 * shortens; fs_fmod_2pi as fmodf(x, 2 pi) and fs_ceil_int as (int)ceilf
 * bit for bit (their libm functions are no longer in the image).
 */
#include <float.h>
#include <stdint.h>
#include <string.h>

#include "control/fs_math.h"
#include "tests/fs_test.h"

/* |f - exact| in units of the float spacing at f (f normal or zero). */
static double ulps(float f, double exact)
{
    int e;
    frexp(fabs((double)f) > 0.0 ? (double)f : exact, &e);
    const double ulp = ldexp(1.0, (e - 24 > -149 ? e - 24 : -149));
    return fabs((double)f - exact) / ulp;
}

static double worst_c, worst_s;
static long n_args, n_rounded;

static void check_angle(float x)
{
    const double c = cos((double)x), s = sin((double)x);
    const float fc = fs_cosf(x), fs = fs_sinf(x);
    const double ec = ulps(fc, c), es = ulps(fs, s);
    if (ec > worst_c) worst_c = ec;
    if (es > worst_s) worst_s = es;
    FS_CHECK(ec < 1.0 && es < 1.0, "fs_cis(%.9g) = (%.9g, %.9g): %.3f, %.3f ulp from (%.17g, %.17g)",
             x, fc, fs, ec, es, c, s);
    ++n_args;
    n_rounded += (fc == (float)c) + (fs == (float)s);
}

/* The previous fs_wrap_pi: fmodf on every argument off the interval. */
static float wrap_fmod(float x)
{
    if (x > FS_PI || x <= -FS_PI) {
        x = fmodf(x, FS_TWO_PI);
        if (x > FS_PI) x -= FS_TWO_PI;
        else if (x <= -FS_PI) x += FS_TWO_PI;
    }
    return x;
}

static int same_bits(float a, float b) { return memcmp(&a, &b, sizeof a) == 0; }

int main(void)
{
    /* Every float of |x| < 8 (a stride over the bit patterns, both signs). */
    for (uint32_t bits = 0; bits < 0x41000000u; bits += 331) {
        float x;
        memcpy(&x, &bits, sizeof x);
        check_angle(x);
        check_angle(-x);
    }
    /* Uniform angles in (-4, 4): what the drive passes (wrapped angles, a step beyond). */
    long uniform0 = n_args, rounded0 = n_rounded;
    uint32_t r = 12345u;
    for (int k = 0; k < 1000000; ++k) {
        r = r * 1664525u + 1013904223u;
        check_angle(-4.0f + 8.0f * (float)(r >> 8) / 16777216.0f);
    }
    const double rounded_pct = 50.0 * (double)(n_rounded - rounded0) / (double)(n_args - uniform0);
    FS_CHECK(rounded_pct >= 95.0, "correctly rounded on %.2f %% of uniform angles, want >= 95 %%", rounded_pct);
    printf("fs_cis: worst %.3f ulp (cos), %.3f ulp (sin); %.2f %% of uniform angles correctly rounded\n",
           worst_c, worst_s, rounded_pct);

    /* The ends of the fast path's range and the multiples of pi/2 (the
     * reduction's cancellation) up to it. */
    for (int k = -126; k <= 126; ++k) {
        const float x = (float)k * (0.5f * FS_PI);
        check_angle(x);
        check_angle(nextafterf(x, 1000.0f));
        check_angle(nextafterf(x, -1000.0f));
    }
    check_angle(nextafterf(199.0f, 0.0f));
    check_angle(-nextafterf(199.0f, 0.0f));

    /* Zero keeps its sign in the sine; NaN and infinities give NaN. */
    FS_CHECK(fs_cosf(0.0f) == 1.0f && fs_cosf(-0.0f) == 1.0f, "cos(0)");
    FS_CHECK(same_bits(fs_sinf(0.0f), 0.0f) && same_bits(fs_sinf(-0.0f), -0.0f), "sin(-0) = %g", fs_sinf(-0.0f));
    const float bad[] = {NAN, INFINITY, -INFINITY};
    for (int k = 0; k < 3; ++k)
        FS_CHECK(isnan(fs_cosf(bad[k])) && isnan(fs_sinf(bad[k])), "fs_cis(%g) not NaN", bad[k]);

    /* From 199 rad on: the value at the wrapped angle, bit for bit. */
    const float large[] = {199.0f, -199.0f, 250.5f, -1234.5678f, 1e5f, -3.3e6f, 1e30f, FLT_MAX};
    for (size_t k = 0; k < sizeof large / sizeof large[0]; ++k) {
        const float w = fs_wrap_pi(large[k]);
        FS_CHECK(same_bits(fs_cosf(large[k]), fs_cosf(w)) && same_bits(fs_sinf(large[k]), fs_sinf(w)),
                 "fs_cis(%.9g) differs from fs_cis of its wrap %.9g", large[k], w);
    }

    /* fs_tanf: sin / cos, within 3 ulp where it is used (|x| < 1.5). */
    double worst_t = 0.0;
    for (int k = -150000; k <= 150000; ++k) {
        const float x = (float)k * 1e-5f;
        const double e = ulps(fs_tanf(x), tan((double)x));
        if (e > worst_t) worst_t = e;
    }
    FS_CHECK(worst_t < 3.0, "fs_tanf: %.3f ulp", worst_t);

    /* fs_atan2f: vectors of every direction and magnitude */
    double worst_a = 0.0;
    long over1 = 0, n_a = 0, rounded_a = 0;
    for (int k = 0; k < 2000000; ++k) {
        r = r * 1664525u + 1013904223u;
        const double ang = -FS_TEST_PI + 2.0 * FS_TEST_PI * (double)(r >> 8) / 16777216.0;
        r = r * 1664525u + 1013904223u;
        const double mag = pow(10.0, -30.0 + 68.0 * (double)(r >> 8) / 16777216.0);
        const float y = (float)(mag * sin(ang)), x = (float)(mag * cos(ang));
        const double exact = atan2((double)y, (double)x);
        const float a = fs_atan2f(y, x);
        const double e = ulps(a, exact);
        if (e > worst_a) worst_a = e;
        over1 += e > 1.0;
        rounded_a += a == (float)exact;
        ++n_a;
        FS_CHECK(e < 1.6, "fs_atan2f(%.9g, %.9g) = %.9g: %.3f ulp from %.17g", y, x, a, e, exact);
    }
    printf("fs_atan2f: worst %.3f ulp, over 1 ulp on %.3f %%, correctly rounded on %.2f %%\n",
           worst_a, 100.0 * (double)over1 / (double)n_a, 100.0 * (double)rounded_a / (double)n_a);
    FS_CHECK((double)over1 / (double)n_a < 1e-3 && (double)rounded_a / (double)n_a > 0.85, "fs_atan2f's rounding");
    /* C99 Annex F: zeros by their sign, infinities, NaN; and atan(x) = atan2(x, 1) */
    const float spec[][3] = {
        {0.0f, 1.0f, 0.0f}, {-0.0f, 1.0f, -0.0f}, {0.0f, -1.0f, FS_PI}, {-0.0f, -1.0f, -FS_PI},
        {0.0f, 0.0f, 0.0f}, {-0.0f, 0.0f, -0.0f}, {0.0f, -0.0f, FS_PI}, {-0.0f, -0.0f, -FS_PI},
        {1.0f, 0.0f, 0.5f * FS_PI}, {-1.0f, -0.0f, -0.5f * FS_PI}, {INFINITY, 1.0f, 0.5f * FS_PI},
        {-INFINITY, -1.0f, -0.5f * FS_PI}, {1.0f, INFINITY, 0.0f}, {-1.0f, INFINITY, -0.0f},
        {1.0f, -INFINITY, FS_PI}, {-1.0f, -INFINITY, -FS_PI}, {INFINITY, INFINITY, 0.25f * FS_PI},
        {-INFINITY, -INFINITY, -0.75f * FS_PI}, {FLT_MAX, FLT_MAX, 0.25f * FS_PI}, {FLT_MAX, -FLT_MAX, 0.75f * FS_PI}};
    for (size_t k = 0; k < sizeof spec / sizeof spec[0]; ++k) {
        const float a = fs_atan2f(spec[k][0], spec[k][1]);
        FS_CHECK(same_bits(a, spec[k][2]) || fabsf(a - spec[k][2]) <= 2e-7f * fabsf(spec[k][2]),
                 "fs_atan2f(%g, %g) = %.9g, want %.9g", spec[k][0], spec[k][1], a, spec[k][2]);
    }
    FS_CHECK(isnan(fs_atan2f(NAN, 1.0f)) && isnan(fs_atan2f(1.0f, NAN)), "fs_atan2f with NaN");
    for (int k = -1000; k <= 1000; ++k) {
        const float x = (float)k * 0.01f;
        FS_CHECK(ulps(fs_atanf(x), atan((double)x)) < 1.6, "fs_atanf(%g)", x);
    }

    /* fs_maxf, fs_minf: the larger (smaller), the number beside a NaN, the
     * first where equal. */
    FS_CHECK(fs_maxf(1.0f, 2.0f) == 2.0f && fs_maxf(2.0f, 1.0f) == 2.0f, "max");
    FS_CHECK(fs_minf(1.0f, 2.0f) == 1.0f && fs_minf(2.0f, 1.0f) == 1.0f, "min");
    FS_CHECK(fs_maxf(NAN, 1.0f) == 1.0f && fs_maxf(1.0f, NAN) == 1.0f, "max with NaN");
    FS_CHECK(fs_minf(NAN, -1.0f) == -1.0f && fs_minf(-1.0f, NAN) == -1.0f, "min with NaN");
    FS_CHECK(isnan(fs_maxf(NAN, NAN)) && isnan(fs_minf(NAN, NAN)), "both NaN");
    FS_CHECK(same_bits(fs_maxf(-0.0f, 0.0f), -0.0f) && same_bits(fs_minf(0.0f, -0.0f), 0.0f), "equal: the first");
    FS_CHECK(fs_maxf(-INFINITY, -1e30f) == -1e30f && fs_minf(INFINITY, 1e30f) == 1e30f, "infinities");

    /* fs_wrap_pi (through fs_wrap_far) gives the fmodf path's bits: every
     * float of |x| < 16, and a stride beyond. */
    long differ = 0;
    for (uint64_t b = 0; b < 0x7f800000u; b += (b < 0x41800000u ? 97u : 65537u)) {
        float x;
        const uint32_t bits = (uint32_t)b;
        memcpy(&x, &bits, sizeof x);
        differ += !same_bits(fs_wrap_pi(x), wrap_fmod(x)) + !same_bits(fs_wrap_pi(-x), wrap_fmod(-x));
    }
    FS_CHECK(differ == 0, "fs_wrap_pi differs from the fmodf path on %ld arguments", differ);

    /* fs_fmod_2pi is fmodf(x, 2 pi) bit for bit: the floats from 0 to 64 pi
     * (a stride of 7), a stride over the rest of the finite ones, both signs
     * (zero remainders keep x's sign), the infinities and a NaN. */
    long fmod_differ = 0;
    for (uint64_t b = 0; b < 0x7f800000u; b += (b < 0x43490fdbu ? 7u : 4099u)) {
        float x;
        const uint32_t bits = (uint32_t)b;
        memcpy(&x, &bits, sizeof x);
        fmod_differ += !same_bits(fs_fmod_2pi(x), fmodf(x, FS_TWO_PI)) + !same_bits(fs_fmod_2pi(-x), fmodf(-x, FS_TWO_PI));
    }
    const float whole[] = {FS_TWO_PI, 2.0f * FS_TWO_PI, 1024.0f * FS_TWO_PI, FLT_MAX, 3.0f * FS_TWO_PI};
    for (size_t k = 0; k < sizeof whole / sizeof whole[0]; ++k) {
        fmod_differ += !same_bits(fs_fmod_2pi(whole[k]), fmodf(whole[k], FS_TWO_PI))
                       + !same_bits(fs_fmod_2pi(-whole[k]), fmodf(-whole[k], FS_TWO_PI));
    }
    FS_CHECK(fmod_differ == 0, "fs_fmod_2pi differs from fmodf on %ld arguments", fmod_differ);
    FS_CHECK(isnan(fs_fmod_2pi(INFINITY)) && isnan(fs_fmod_2pi(-INFINITY)) && isnan(fs_fmod_2pi(NAN)),
             "fs_fmod_2pi of an infinity or NaN is NaN, as fmodf");

    /* fs_ceil_int is (int)ceilf: every float of |x| < 2^24 (a stride), both signs, and the ends */
    long ceil_differ = 0;
    for (uint32_t bits = 0; bits < 0x4b800000u; bits += 13) {
        float x;
        memcpy(&x, &bits, sizeof x);
        ceil_differ += (fs_ceil_int(x) != (int)ceilf(x)) + (fs_ceil_int(-x) != (int)ceilf(-x));
    }
    const float ceil_ends[] = {0.5f, -0.5f, 1.0f, nextafterf(1.0f, 2.0f), 8388607.5f, 8388608.0f, 1e9f, -1e9f};
    for (size_t k = 0; k < sizeof ceil_ends / sizeof ceil_ends[0]; ++k) ceil_differ += fs_ceil_int(ceil_ends[k]) != (int)ceilf(ceil_ends[k]);
    FS_CHECK(ceil_differ == 0, "fs_ceil_int differs from (int)ceilf on %ld arguments", ceil_differ);

    /* fs_cis_small is fs_cis bit for bit: every float of |x| < 1 (its inline
     * path below 0.78, the call beyond; a stride), both signs, and the ends. */
    long small_differ = 0;
    for (uint32_t bits = 0; bits <= 0x3f800000u; bits += 7) {
        float x;
        memcpy(&x, &bits, sizeof x);
        for (int sg = 0; sg < 2; ++sg, x = -x) {
            const float _Complex a = fs_cis_small(x), b = fs_cis(x);
            small_differ += memcmp(&a, &b, sizeof a) != 0;
        }
    }
    const float ends[] = {0.78f, -0.78f, nextafterf(0.78f, 0.0f), -nextafterf(0.78f, 0.0f), 3.0f, -200.0f, NAN, INFINITY};
    for (size_t k = 0; k < sizeof ends / sizeof ends[0]; ++k) {
        const float _Complex a = fs_cis_small(ends[k]), b = fs_cis(ends[k]);
        small_differ += memcmp(&a, &b, sizeof a) != 0;
    }
    FS_CHECK(small_differ == 0, "fs_cis_small differs from fs_cis on %ld arguments", small_differ);
    return fs_test_summary("test_trig");
}
