/* fs-test-sources: control/fs_pwm5.c control/fs_vsd.c
 *
 * fs_pwm5 (nearest-four-vector SVPWM, five phases), everything measured with
 * a double-precision VSD written here, independent of fs_vsd.c:
 * - enumeration of the 32 switching states (star-connected load): 2 zero
 *   vectors, 10 large (0.8 cos(pi/5) u_dc), 10 medium (0.4 u_dc), 10 small
 *   (0.8 cos(2pi/5) u_dc); large and medium ones one each at every multiple of
 *   36 degrees; a large vector's x-y image is small-sized, a medium one's is
 *   medium-sized, and an aligned large/medium pair has opposite x-y images;
 *   fs_vsd5_forward agrees with the enumeration.
 * - linear range (|u| <= u_dc / (2 cos(pi/10))), all angles, three u_dc: not
 *   flagged; duties in [0, 1]; the duties' mean alpha-beta voltage (here and
 *   by fs_pwm5_voltage) and u_real equal the reference; their x-y voltage is
 *   zero. The period's switching sequence (legs switch in the order of their
 *   duties) is rebuilt from the sorted duties: its volt-seconds over the
 *   enumerated state vectors give the reference and zero x-y; every active
 *   state with a non-zero dwell is one of the two large and two medium vectors
 *   at the edges of the reference's 36-degree sector (either sector at a
 *   boundary); away from the boundaries all four are used, each aligned
 *   large/medium pair in the ratio 2 cos(pi/5) (x-y cancellation); the zero
 *   vectors at both ends have equal dwell (1 - 2 cos(pi/10) m cos(phi)) / 2.
 * - beyond the limit: flagged, realised vector (u_real and the duties) on the
 *   limit circle at the reference's angle, x-y still zero, still NFV states.
 * - u_dc <= 0, non-finite u_dc or reference: duties 0.5, u_real 0, flagged.
 */
#include <float.h>
#include <stdint.h>

#include "control/fs_pwm5.h"
#include "control/fs_vsd.h"
#include "tests/fs_test.h"

static const double G = 2.0 * FS_TEST_PI / 5.0;
static const double SEC = FS_TEST_PI / 5.0; /* 36 degrees */

enum { ZERO, SMALL, MEDIUM, LARGE };

/* The enumerated states, in units of u_dc: bit k of the index = leg k high. */
static double st_ab[32][2], st_xy[32][2];
static int st_class[32], st_edge[32];
static uint32_t nfv_mask[10]; /* states of the NFV set of sector n */

/* Double VSD of the phase voltages a star-connected load sees. */
static void vsd_d(const double pole[5], double ab[2], double xy[2])
{
    double mean = 0.2 * (pole[0] + pole[1] + pole[2] + pole[3] + pole[4]);
    ab[0] = ab[1] = xy[0] = xy[1] = 0.0;
    for (int k = 0; k < 5; ++k) {
        double u = pole[k] - mean;
        ab[0] += 0.4 * u * cos(k * G);
        ab[1] += 0.4 * u * sin(k * G);
        xy[0] += 0.4 * u * cos(3.0 * k * G);
        xy[1] += 0.4 * u * sin(3.0 * k * G);
    }
}

static int popcount32(uint32_t m)
{
    int n = 0;
    for (; m; m &= m - 1) ++n;
    return n;
}

static double wrap_2pi(double a)
{
    a = fmod(a, 2.0 * FS_TEST_PI);
    return a < 0.0 ? a + 2.0 * FS_TEST_PI : a;
}

static void enumerate(void)
{
    const double L = 0.8 * cos(FS_TEST_PI / 5.0), M = 0.4, S = 0.8 * cos(2.0 * FS_TEST_PI / 5.0);
    int count[4] = {0, 0, 0, 0}, per_edge[10][4] = {{0}};
    for (int s = 0; s < 32; ++s) {
        double pole[5];
        float pole_f[5];
        for (int k = 0; k < 5; ++k) pole_f[k] = (float)(pole[k] = (s >> k) & 1);
        vsd_d(pole, st_ab[s], st_xy[s]);
        double mag = hypot(st_ab[s][0], st_ab[s][1]);
        int c = -1;
        if (mag < 1e-9) c = ZERO;
        else if (fabs(mag - S) < 1e-9) c = SMALL;
        else if (fabs(mag - M) < 1e-9) c = MEDIUM;
        else if (fabs(mag - L) < 1e-9) c = LARGE;
        FS_CHECK(c >= 0, "state %d: magnitude %.12g is none of 0, small, medium, large", s, mag);
        if (c < 0) c = ZERO;
        st_class[s] = c;
        ++count[c];
        /* the module's VSD sees the same vectors (pole voltages; the zero
         * sequence goes to .zero) */
        fs_vsd5 v = fs_vsd5_forward(pole_f);
        FS_CHECK_NEAR(v.ab.alpha, st_ab[s][0], 1e-6, "fs_vsd5_forward of a state: alpha");
        FS_CHECK_NEAR(v.ab.beta, st_ab[s][1], 1e-6, "fs_vsd5_forward of a state: beta");
        FS_CHECK_NEAR(v.xy.alpha, st_xy[s][0], 1e-6, "fs_vsd5_forward of a state: x");
        FS_CHECK_NEAR(v.xy.beta, st_xy[s][1], 1e-6, "fs_vsd5_forward of a state: y");
        st_edge[s] = -1;
        if (c == LARGE || c == MEDIUM) {
            double a = wrap_2pi(atan2(st_ab[s][1], st_ab[s][0]));
            int e = (int)floor(a / SEC + 0.5) % 10;
            FS_CHECK(fabs(fs_test_wrap(a - e * SEC)) < 1e-9, "state %d: angle %.12g not a multiple of 36 deg", s, a);
            st_edge[s] = e;
            ++per_edge[e][c];
            /* x-y image: large -> small-sized, medium -> medium-sized */
            double xy_mag = hypot(st_xy[s][0], st_xy[s][1]);
            FS_CHECK_NEAR(xy_mag, c == LARGE ? S : M, 1e-9, "x-y image size of a large/medium vector");
        }
    }
    FS_CHECK(count[ZERO] == 2 && count[SMALL] == 10 && count[MEDIUM] == 10 && count[LARGE] == 10,
             "classes: %d zero, %d small, %d medium, %d large", count[ZERO], count[SMALL], count[MEDIUM],
             count[LARGE]);
    for (int e = 0; e < 10; ++e) {
        FS_CHECK(per_edge[e][LARGE] == 1 && per_edge[e][MEDIUM] == 1, "edge %d: %d large, %d medium", e,
                 per_edge[e][LARGE], per_edge[e][MEDIUM]);
    }
    /* NFV sets; aligned large/medium pairs have opposite x-y images */
    for (int n = 0; n < 10; ++n) nfv_mask[n] = 0;
    for (int s = 0; s < 32; ++s) {
        if (st_edge[s] < 0) continue;
        nfv_mask[st_edge[s]] |= 1u << s;
        nfv_mask[(st_edge[s] + 9) % 10] |= 1u << s;
        for (int t = 0; t < 32; ++t) {
            if (st_edge[t] == st_edge[s] && st_class[s] == LARGE && st_class[t] == MEDIUM) {
                double dot = st_xy[s][0] * st_xy[t][0] + st_xy[s][1] * st_xy[t][1];
                FS_CHECK_NEAR(dot, -S * M, 1e-9, "aligned large/medium: opposite x-y images");
            }
        }
    }
    for (int n = 0; n < 10; ++n) FS_CHECK_EQ_INT(popcount32(nfv_mask[n]), 4, "NFV set size");
}

static void check_duties_range(const float duty[5], const char *what, double mag, double th)
{
    for (int k = 0; k < 5; ++k) {
        FS_CHECK(duty[k] >= 0.0f && duty[k] <= 1.0f, "%s |u| = %g th = %g: duty[%d] = %.9g", what, mag, th, k,
                 duty[k]);
    }
}

/* The switching sequence of one carrier period and its checks.
 * m: realised magnitude / u_dc, th: its angle. */
static void check_sequence(const float duty[5], double m, double th, double u_dc, double ref_ab[2])
{
    int ord[5] = {0, 1, 2, 3, 4};
    for (int i = 1; i < 5; ++i) { /* descending duties, ties by index */
        for (int j = i; j > 0 && duty[ord[j]] > duty[ord[j - 1]]; --j) {
            int t = ord[j];
            ord[j] = ord[j - 1];
            ord[j - 1] = t;
        }
    }
    /* State i (i = 0..5): the i legs with the largest duties high. */
    double dw[32] = {0.0}, dwell[6];
    int state[6];
    int s = 0;
    for (int i = 0; i <= 5; ++i) {
        if (i > 0) s |= 1 << ord[i - 1];
        state[i] = s;
        double hi = i == 0 ? 1.0 : duty[ord[i - 1]], lo = i == 5 ? 0.0 : duty[ord[i]];
        dwell[i] = hi - lo;
        dw[s] += dwell[i];
    }
    FS_CHECK(state[0] == 0 && state[5] == 31, "zero vectors at both ends");
    /* volt-seconds over the enumerated state vectors */
    double ab[2] = {0, 0}, xy[2] = {0, 0};
    for (int t = 0; t < 32; ++t) {
        ab[0] += dw[t] * st_ab[t][0];
        ab[1] += dw[t] * st_ab[t][1];
        xy[0] += dw[t] * st_xy[t][0];
        xy[1] += dw[t] * st_xy[t][1];
    }
    double tol = 2e-6 * u_dc;
    FS_CHECK_NEAR(ab[0] * u_dc, ref_ab[0], tol, "sequence volt-seconds: alpha");
    FS_CHECK_NEAR(ab[1] * u_dc, ref_ab[1], tol, "sequence volt-seconds: beta");
    FS_CHECK_NEAR(xy[0] * u_dc, 0.0, tol, "sequence volt-seconds: x");
    FS_CHECK_NEAR(xy[1] * u_dc, 0.0, tol, "sequence volt-seconds: y");
    /* zero vectors: equal dwell at both ends, as predicted */
    double phi = th - SEC / 2.0;
    phi -= SEC * floor(phi / SEC + 0.5);
    double z = 0.5 * (1.0 - 2.0 * cos(FS_TEST_PI / 10.0) * m * cos(phi));
    FS_CHECK_NEAR(dwell[0], z, 2e-6, "dwell of 00000");
    FS_CHECK_NEAR(dwell[5], z, 2e-6, "dwell of 11111");
    if (m < 1e-3) return; /* no meaningful angle */
    /* the active states used: the reference's sector's NFV set */
    double a = wrap_2pi(th);
    int n = (int)floor(a / SEC) % 10;
    double off = a - n * SEC, edge_dist = fmin(off, SEC - off);
    uint32_t allowed = nfv_mask[n];
    if (off < 1e-4) allowed |= nfv_mask[(n + 9) % 10];
    if (SEC - off < 1e-4) allowed |= nfv_mask[(n + 1) % 10];
    uint32_t used = 0;
    for (int i = 1; i <= 4; ++i) {
        if (dwell[i] > 1e-6) used |= 1u << state[i];
    }
    FS_CHECK((used & ~allowed) == 0, "m = %g th = %.9g: active states 0x%08x outside the NFV set 0x%08x", m, th,
             (unsigned)used, (unsigned)allowed);
    if (edge_dist > 0.5 * FS_TEST_PI / 180.0 && m > 0.005) {
        FS_CHECK(used == nfv_mask[n], "m = %g th = %.9g: active states 0x%08x, NFV set 0x%08x", m, th,
                 (unsigned)used, (unsigned)nfv_mask[n]);
        /* aligned pairs in the golden ratio: x-y cancellation */
        for (int e = n; e <= n + 1; ++e) {
            double t_l = 0.0, t_m = 0.0;
            for (int t = 0; t < 32; ++t) {
                if (st_edge[t] != e % 10) continue;
                if (st_class[t] == LARGE) t_l = dw[t];
                if (st_class[t] == MEDIUM) t_m = dw[t];
            }
            FS_CHECK_NEAR(t_l, 2.0 * cos(FS_TEST_PI / 5.0) * t_m, 1e-5, "large/medium dwell ratio 2 cos(pi/5)");
        }
    }
}

/* Everything about one call. */
static void one(double mag, double th, float u_dc)
{
    const double lim = 1.0 / (2.0 * cos(FS_TEST_PI / 10.0));
    fs_ab ref = {(float)(mag * cos(th)), (float)(mag * sin(th))};
    float duty[5] = {-1.0f, -1.0f, -1.0f, -1.0f, -1.0f};
    fs_ab u_real = {NAN, NAN};
    bool over = fs_pwm5(ref, u_dc, duty, &u_real);
    check_duties_range(duty, "", mag, th);
    double pole[5], ab[2], xy[2];
    for (int k = 0; k < 5; ++k) pole[k] = (double)duty[k] * u_dc;
    vsd_d(pole, ab, xy);
    fs_ab u = fs_pwm5_voltage(duty, u_dc);
    double tol = 2e-6 * u_dc;
    FS_CHECK_NEAR(u.alpha, ab[0], tol, "fs_pwm5_voltage: alpha");
    FS_CHECK_NEAR(u.beta, ab[1], tol, "fs_pwm5_voltage: beta");
    FS_CHECK_NEAR(u_real.alpha, ab[0], tol, "u_real: alpha");
    FS_CHECK_NEAR(u_real.beta, ab[1], tol, "u_real: beta");
    FS_CHECK_NEAR(xy[0], 0.0, tol, "x-y voltage: x");
    FS_CHECK_NEAR(xy[1], 0.0, tol, "x-y voltage: y");
    double ref_mag = hypot(ref.alpha, ref.beta), th_ref = atan2(ref.beta, ref.alpha);
    double want[2];
    if (ref_mag <= lim * u_dc * (1.0 - 1e-6)) {
        FS_CHECK(!over, "|u| = %g inside the limit %g flagged", ref_mag, lim * u_dc);
        want[0] = ref.alpha;
        want[1] = ref.beta;
        FS_CHECK_NEAR(ab[0], want[0], tol, "linear: alpha");
        FS_CHECK_NEAR(ab[1], want[1], tol, "linear: beta");
        check_sequence(duty, ref_mag / u_dc, th_ref, u_dc, want);
    } else if (ref_mag >= lim * u_dc * (1.0 + 1e-6)) {
        FS_CHECK(over, "|u| = %g beyond the limit %g not flagged", ref_mag, lim * u_dc);
        double r_mag = hypot(ab[0], ab[1]), r_th = atan2(ab[1], ab[0]);
        FS_CHECK(fabs(fs_test_wrap(r_th - th_ref)) <= 1e-5, "over: |u| = %g th = %g realised angle %.9g", ref_mag,
                 th_ref, r_th);
        FS_CHECK_NEAR(r_mag, lim * u_dc, tol, "over: realised magnitude on the limit");
        FS_CHECK_NEAR(hypot(u_real.alpha, u_real.beta), lim * u_dc, tol, "over: |u_real| on the limit");
        FS_CHECK(fabs(fs_test_wrap(atan2(u_real.beta, u_real.alpha) - th_ref)) <= 1e-5, "over: u_real angle");
        want[0] = lim * u_dc * cos(th_ref);
        want[1] = lim * u_dc * sin(th_ref);
        check_sequence(duty, lim, th_ref, u_dc, want);
    }
}

static void degenerate(fs_ab ref, float u_dc, const char *what)
{
    float duty[5] = {-1.0f, -1.0f, -1.0f, -1.0f, -1.0f};
    fs_ab u_real = {NAN, NAN};
    bool over = fs_pwm5(ref, u_dc, duty, &u_real);
    for (int k = 0; k < 5; ++k) FS_CHECK(duty[k] == 0.5f, "%s: duty[%d] = %g", what, k, duty[k]);
    FS_CHECK(u_real.alpha == 0.0f && u_real.beta == 0.0f, "%s: u_real = (%g, %g)", what, u_real.alpha,
             u_real.beta);
    FS_CHECK(over, "%s: not flagged", what);
}

int main(void)
{
    enumerate();
    const double lim = 1.0 / (2.0 * cos(FS_TEST_PI / 10.0));
    const float dcs[] = {600.0f, 48.0f, 1.0f};
    const double fr[] = {0.0,    1e-6, 0.01, 0.1, 0.3,   0.5, 0.7, 0.9, 0.99, 0.9999, 0.999999,
                         1.0001, 1.01, 1.03, 1.1, 1.2, 2.0, 10.0, 1e4, 1e30};
    for (int u = 0; u < 3; ++u) {
        for (int f = 0; f < (int)(sizeof fr / sizeof fr[0]); ++f) {
            double mag = fr[f] * lim * dcs[u];
            for (int k = 0; k < 720; ++k) one(mag, k * 2.0 * FS_TEST_PI / 720.0 + 1e-3, dcs[u]);
            /* sector boundaries (0, 36, ... deg) and middles (18, 54, ... deg) */
            for (int k = -20; k <= 20; ++k) one(mag, k * FS_TEST_PI / 10.0, dcs[u]);
        }
    }
    /* At the limit in a sector middle the legs span the whole dc link. */
    float duty[5];
    fs_ab real;
    double th = FS_TEST_PI / 10.0;
    fs_ab ref = {(float)(0.999999 * lim * 600.0 * cos(th)), (float)(0.999999 * lim * 600.0 * sin(th))};
    fs_pwm5(ref, 600.0f, duty, &real);
    double dmax = 0.0, dmin = 1.0;
    for (int k = 0; k < 5; ++k) {
        dmax = fmax(dmax, duty[k]);
        dmin = fmin(dmin, duty[k]);
    }
    FS_CHECK(dmax > 1.0 - 1e-5 && dmin < 1e-5, "limit at 18 deg: duties span [%g, %g]", dmin, dmax);
    /* Huge finite references and the limit. */
    ref.alpha = FLT_MAX;
    ref.beta = -FLT_MAX;
    bool over = fs_pwm5(ref, 600.0f, duty, &real);
    check_duties_range(duty, "FLT_MAX", 0.0, 0.0);
    FS_CHECK(over, "FLT_MAX reference not flagged");
    FS_CHECK_NEAR(real.alpha, lim * 600.0 / sqrt(2.0), 1e-3, "FLT_MAX reference: alpha");
    FS_CHECK_NEAR(real.beta, -lim * 600.0 / sqrt(2.0), 1e-3, "FLT_MAX reference: beta");
    /* Zero reference: all 0.5, not flagged; u_real may be NULL. */
    ref.alpha = ref.beta = 0.0f;
    over = fs_pwm5(ref, 600.0f, duty, NULL);
    for (int k = 0; k < 5; ++k) FS_CHECK(duty[k] == 0.5f, "zero reference: duty[%d] = %g", k, duty[k]);
    FS_CHECK(!over, "zero reference flagged");
    /* Degenerate inputs. */
    fs_ab r = {100.0f, -50.0f}, r_nan = {NAN, 0.0f}, r_inf = {0.0f, -INFINITY};
    degenerate(r, 0.0f, "u_dc = 0");
    degenerate(r, -10.0f, "u_dc < 0");
    degenerate(r, NAN, "u_dc = NaN");
    degenerate(r, INFINITY, "u_dc = inf");
    degenerate(r_nan, 600.0f, "NaN reference");
    degenerate(r_inf, 600.0f, "infinite reference");
    /* fs_pwm5_voltage: one leg high is a medium vector, 0.4 u_dc along it;
     * a common duty offset changes nothing. */
    for (int k = 0; k < 5; ++k) {
        float d[5] = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f}, d2[5];
        d[k] = 1.0f;
        fs_ab v = fs_pwm5_voltage(d, 300.0f);
        FS_CHECK_NEAR(v.alpha, 120.0 * cos(k * G), 1e-4, "one leg high: alpha");
        FS_CHECK_NEAR(v.beta, 120.0 * sin(k * G), 1e-4, "one leg high: beta");
        for (int j = 0; j < 5; ++j) d2[j] = 0.3f * d[j] + 0.5f;
        v = fs_pwm5_voltage(d2, 300.0f);
        FS_CHECK_NEAR(v.alpha, 36.0 * cos(k * G), 1e-4, "with a common offset: alpha");
        FS_CHECK_NEAR(v.beta, 36.0 * sin(k * G), 1e-4, "with a common offset: beta");
    }
    return fs_test_summary("test_pwm5");
}
