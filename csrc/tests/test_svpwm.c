/* fs-test-sources: control/fs_svpwm.c control/fs_transforms.c
 *
 * fs_svpwm: duties in [0, 1]; linear range (|u| <= u_dc/sqrt3): realised
 * voltage (fs_svpwm_voltage of the duties) equals the reference within 1e-4
 * relative (everywhere inside the hexagon, in fact), min-max injection centres
 * the duties; beyond the hexagon: the
 * realised vector keeps the reference's angle (1e-4 rad), lies on the hexagon
 * (max minus min pole voltage = u_dc), is no longer than the reference, and
 * u_real reports it; u_dc <= 0 gives 0.5 duties.
 */
#include <float.h>
#include "control/fs_svpwm.h"
#include "tests/fs_test.h"

static double ang_diff(double a, double b)
{
    double d = fmod(a - b, 2.0 * FS_TEST_PI);
    if (d > FS_TEST_PI) d -= 2.0 * FS_TEST_PI;
    if (d < -FS_TEST_PI) d += 2.0 * FS_TEST_PI;
    return d;
}

static void one(double mag, double th, float u_dc)
{
    fs_ab ref = {(float)(mag * cos(th)), (float)(mag * sin(th))};
    float duty[3] = {-1.0f, -1.0f, -1.0f};
    fs_ab u_real = {NAN, NAN};
    bool over = fs_svpwm(ref, u_dc, duty, &u_real);
    for (int k = 0; k < 3; ++k) {
        FS_CHECK(duty[k] >= 0.0f && duty[k] <= 1.0f, "|u| = %g, th = %g: duty[%d] = %.9g", mag, th, k, duty[k]);
    }
    fs_ab u = fs_svpwm_voltage(duty, u_dc);
    double ref_mag = hypot(ref.alpha, ref.beta), u_mag = hypot(u.alpha, u.beta);
    double dmax = fmax(duty[0], fmax(duty[1], duty[2])), dmin = fmin(duty[0], fmin(duty[1], duty[2]));
    double lin = u_dc / sqrt(3.0);
    /* The hexagon's radius in the reference's direction: u_dc/sqrt3 at the
     * edge middles (30, 90, ... degrees), 2/3 u_dc at the vertices (0, 60, ...). */
    double phi = th - FS_TEST_PI / 6.0;
    phi -= FS_TEST_PI / 3.0 * floor(phi / (FS_TEST_PI / 3.0) + 0.5);
    double hex = lin / cos(phi);
    /* the voltage it reports is the one the duties realise */
    FS_CHECK_NEAR(u_real.alpha, u.alpha, 1e-4 * u_mag + 1e-6 * u_dc, "u_real.alpha vs duties");
    FS_CHECK_NEAR(u_real.beta, u.beta, 1e-4 * u_mag + 1e-6 * u_dc, "u_real.beta vs duties");
    if (mag <= hex * (1.0 - 1e-6)) {
        FS_CHECK(!over, "|u| = %g inside the hexagon (%g) flagged as over-modulation", mag, hex);
        FS_CHECK_NEAR(u.alpha, ref.alpha, 1e-4 * ref_mag + 1e-6 * u_dc, "linear: alpha");
        FS_CHECK_NEAR(u.beta, ref.beta, 1e-4 * ref_mag + 1e-6 * u_dc, "linear: beta");
        FS_CHECK_NEAR(dmax + dmin, 1.0, 1e-6, "min-max injection centres the duties");
    } else if (mag >= hex * (1.0 + 1e-5)) {
        FS_CHECK(over, "|u| = %g beyond the hexagon (%g) not flagged", mag, hex);
        FS_CHECK(fabs(ang_diff(atan2(u.beta, u.alpha), th)) <= 1e-4, "over: |u| = %g th = %g realised angle %.9g",
                 mag, th, atan2(u.beta, u.alpha));
        FS_CHECK_NEAR((dmax - dmin) * u_dc, u_dc, 1e-5 * u_dc, "over: on the hexagon (span = u_dc)");
        FS_CHECK(u_mag <= ref_mag * (1.0 + 1e-6), "over: realised %g longer than the reference %g", u_mag, ref_mag);
        FS_CHECK(u_mag >= lin * (1.0 - 1e-5) && u_mag <= 2.0 / 3.0 * u_dc * (1.0 + 1e-5),
                 "over: realised magnitude %g outside [u_dc/sqrt3, 2/3 u_dc]", u_mag);
    }
}

int main(void)
{
    {   /* an infinity or a NaN anywhere: 0.5 on every leg; the largest finite values are modulated */
        const float bad[] = {INFINITY, -INFINITY, NAN};
        for (int b = 0; b < 3; ++b) {
            for (int where = 0; where < 3; ++where) {
                fs_ab ref = {where == 0 ? bad[b] : 10.0f, where == 1 ? bad[b] : -10.0f};
                float duty[3] = {-1.0f, -1.0f, -1.0f};
                fs_svpwm(ref, where == 2 ? bad[b] : 48.0f, duty, NULL);
                FS_CHECK(duty[0] == 0.5f && duty[1] == 0.5f && duty[2] == 0.5f, "non-finite input %d at %d: 0.5", b, where);
            }
        }
        float duty[3] = {-1.0f, -1.0f, -1.0f};
        fs_svpwm((fs_ab){FLT_MAX, -FLT_MAX}, FLT_MAX, duty, NULL);
        FS_CHECK(duty[0] > 0.99f && duty[1] < 0.01f, "FLT_MAX is finite: modulated (%g %g)", duty[0], duty[1]);
    }
    const float dcs[] = {600.0f, 48.0f, 1.0f};
    const double fr[] = {0.0, 1e-6, 0.01, 0.1, 0.5, 0.9, 0.99, 0.9999, 1.0,
                         1.0001, 1.01, 1.1, 1.1547, 1.2, 1.5, 2.0, 10.0, 1e4};
    for (int u = 0; u < 3; ++u) {
        for (int f = 0; f < (int)(sizeof fr / sizeof fr[0]); ++f) {
            for (int k = 0; k < 720; ++k) {
                one(fr[f] * dcs[u] / sqrt(3.0), k * 2.0 * FS_TEST_PI / 720.0 + 1e-3, dcs[u]);
            }
            /* exactly at the sector boundaries and the vertices */
            for (int k = -6; k <= 6; ++k) one(fr[f] * dcs[u] / sqrt(3.0), k * FS_TEST_PI / 6.0, dcs[u]);
        }
    }
    /* At a vertex the realised magnitude reaches 2/3 u_dc. */
    float duty[3];
    fs_ab real;
    fs_ab ref = {1000.0f, 0.0f};
    fs_svpwm(ref, 600.0f, duty, &real);
    FS_CHECK_NEAR(hypot(real.alpha, real.beta), 400.0, 1e-3, "vertex magnitude 2/3 u_dc");
    FS_CHECK(duty[0] == 1.0f && duty[1] == 0.0f && duty[2] == 0.0f, "vertex duties %g %g %g", duty[0], duty[1],
             duty[2]);
    /* Zero reference: all 0.5. */
    ref.alpha = 0.0f;
    fs_svpwm(ref, 600.0f, duty, &real);
    FS_CHECK(duty[0] == 0.5f && duty[1] == 0.5f && duty[2] == 0.5f, "zero reference");
    /* u_real may be NULL. */
    ref.alpha = 100.0f;
    fs_svpwm(ref, 600.0f, duty, NULL);
    /* No dc link: duties 0.5, nothing realised. */
    for (int s = 0; s < 2; ++s) {
        float dc = s ? -10.0f : 0.0f;
        bool over = fs_svpwm(ref, dc, duty, &real);
        FS_CHECK(duty[0] == 0.5f && duty[1] == 0.5f && duty[2] == 0.5f, "u_dc = %g: duties", dc);
        FS_CHECK(real.alpha == 0.0f && real.beta == 0.0f, "u_dc = %g: realised", dc);
        FS_CHECK(over, "u_dc = %g with a non-zero reference is over-modulation", dc);
    }
    /* fs_svpwm_voltage: duties (1, 0, 0) give 2/3 u_dc on alpha; equal duties give 0. */
    float d100[3] = {1.0f, 0.0f, 0.0f}, dhalf[3] = {0.3f, 0.3f, 0.3f};
    fs_ab v = fs_svpwm_voltage(d100, 300.0f);
    FS_CHECK_NEAR(v.alpha, 200.0, 1e-4, "(1,0,0) alpha");
    FS_CHECK_NEAR(v.beta, 0.0, 1e-4, "(1,0,0) beta");
    v = fs_svpwm_voltage(dhalf, 300.0f);
    FS_CHECK_NEAR(hypot(v.alpha, v.beta), 0.0, 1e-4, "zero sequence gives no voltage");
    return fs_test_summary("test_svpwm");
}
