/* fs-test-sources: sim/fs_profile.c control/fs_blend.c control/fs_current_ctrl.c control/fs_drive.c control/fs_drive_ident.c control/fs_drive_protect.c control/fs_drive_start.c control/fs_dtcomp.c control/fs_fluxmap.c control/fs_fw.c control/fs_fwmap.c control/fs_hfi.c control/fs_hfi_filter.c control/fs_ident.c control/fs_if_start.c control/fs_imc.c control/fs_lock.c control/fs_lpf.c control/fs_mapid.c control/fs_monitor.c control/fs_motion_obs.c control/fs_motion_test.c control/fs_mtpa.c control/fs_param_adapt.c control/fs_pi.c control/fs_pll.c control/fs_polarity.c control/fs_pwm5.c control/fs_smo.c control/fs_speed_ctrl.c control/fs_srff.c control/fs_status.c control/fs_svpwm.c control/fs_swvi.c control/fs_transforms.c control/fs_vsd.c control/fs_xcomp.c control/fs_xyctrl.c plant/fs_grid.c plant/fs_inverter.c plant/fs_losses.c plant/fs_magnetic.c plant/fs_pmsm.c plant/fs_thermal.c 
 *
 * fs_sim.c's fmod_near, fmod_far and wrap_pi (the runner's angle wraps, a sample's
 * library call spared): fmod(x, 2 pi) and the library-only wrap bit for bit,
 * on the values a run produces (an angle one or two sample steps past the
 * band), the band's edges and their neighbours, signed zeros, NaN, the
 * infinities and values far outside the band.
 */
#include <stdint.h>
#include <string.h>

#include "sim/fs_sim.c"
#include "tests/fs_test.h"

static uint64_t bits(double x)
{
    uint64_t u;
    memcpy(&u, &x, sizeof u);
    return u;
}

/* wrap_pi as it was: the library's fmod every time. */
static double wrap_pi_ref(double x)
{
    const double PI = pi_const(), r = fmod(x + PI, 2.0 * PI);
    return (x > -PI && x <= PI) ? x : (r <= 0.0 ? r + 2.0 * PI : r) - PI;
}

static void check(double x)
{
    const double y = 2.0 * pi_const();
    const double a = fmod_near(x, y), b = fmod(x, y);
    FS_CHECK(bits(a) == bits(b) || (isnan(a) && isnan(b)), "fmod_near(%.17g) = %.17g, fmod %.17g", x, a, b);
    const double c = wrap_pi(x), d = wrap_pi_ref(x);
    FS_CHECK(bits(c) == bits(d) || (isnan(c) && isnan(d)), "wrap_pi(%.17g) = %.17g, with fmod %.17g", x, c, d);
}

int main(void)
{
    const double y = 2.0 * pi_const();
    const double edges[] = {0.0, -0.0, y, -y, 2.0 * y, -2.0 * y, 0.5 * y, -0.5 * y, 3.0 * y, -3.0 * y,
                            pi_const(), -pi_const(), 1e300, -1e300, 5e-324, -5e-324, INFINITY, -INFINITY, NAN};
    for (size_t k = 0; k < sizeof edges / sizeof edges[0]; ++k) {
        double e = edges[k];
        check(e);
        double up = e, down = e;
        for (int n = 0; n < 4; ++n) {   /* the neighbours, a few ulp either side */
            up = nextafter(up, INFINITY);
            down = nextafter(down, -INFINITY);
            check(up);
            check(down);
        }
    }
    uint64_t s = 0x9E3779B97F4A7C15ULL;
    for (int n = 0; n < 200000; ++n) {   /* uniform over (-5 y, 5 y): in the band and out */
        double u = rng_uniform(&s);
        check((10.0 * u - 5.0) * y);
    }
    for (int n = 0; n < 200000; ++n) {   /* fmod_far's reach and past it: |x| up to 2^17 y, log-uniform */
        double u = rng_uniform(&s), v = rng_uniform(&s), w = rng_uniform(&s);
        check((w < 0.5 ? -1.0 : 1.0) * ldexp(1.0 + u, (int)(18.0 * v) - 1) * y);
    }
    for (int n = -70000; n <= 70000; n += 7) {   /* whole turns, and a few ulp beside them */
        double e = n * y;
        check(e);
        check(nextafter(e, INFINITY));
        check(nextafter(e, -INFINITY));
    }
    double th = 0.0;   /* an angle advanced by up to a turn a step and wrapped, as advance does */
    for (int n = 0; n < 100000; ++n) {
        th = fmod_near(th + (rng_uniform(&s) * 2.0 - 0.5) * y, y);
        check(th);
    }
    printf("%d checks, %d failures\n", fs_test_checks, fs_test_failures);
    return fs_test_failures != 0;
}
