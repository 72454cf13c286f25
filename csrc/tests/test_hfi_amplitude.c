/* fs-test-sources: control/fs_hfi.c control/fs_xcomp.c control/fs_hfi_filter.c control/fs_srff.c control/fs_motion_obs.c control/fs_transforms.c control/fs_status.c
 *
 * fs_hfi's negative-carrier amplitude beside a large fundamental, with the
 * fundamental's leak removed (cfg.leak): the amplitude eq. (26) is divided
 * by, and the carriers per unit gain a fade adds to the SRFFs' states.
 * Issue 34 item 6 (the rated load's release at standstill on the rotating
 * injection with the designed defaults, bench/estimators.py case b, 8.85
 * el.deg against 5): fs_hfi takes both from the SRFFs' states, which hold
 * the fundamental's leak too (w_b / w_h of it, a tone near w_h), so that
 * under load the error the observer takes is scaled down (by 0.53 at rated
 * load on motulator's 2.2 kW IPMSM with its designed 0.16 A carrier: the
 * release lags 8.85 el.deg where the observer as designed lags 4.9) and a
 * fade scales a snapshot of the leak with the carrier. The mend, in
 * fs_hfi.c, takes the leak's image (leak_p, leak_n) out of both: the
 * release lags 4.10 el.deg. It runs the observer at its designed gain under
 * load, where the leak's inflation had slowed it 4 to 10 times; the drive's
 * resume of the injection at speed (fs_drive.c) follows the back-EMF
 * observer at the filters' bandwidth (fs_hfi_follow) and holds that
 * observer only where it has converged (issue 34).
 *
 * The machine and its integration are test_hfi.c's (there the header says
 * how): R = 0.036 ohm, L_d = 65 uH, L_q = 90 uH, Ts = 1e-4 s, u_h = 5 V,
 * w_h = 2 pi 1 kHz, a fundamental current held by the voltage R i_dc.
 */
#include <complex.h>
#include <string.h>

#include "control/fs_hfi.h"
#include "control/fs_math.h"
#include "tests/fs_test.h"

#include "tests/hfi_plant.h"

/* At standstill with the fundamental i_dc held, the injection's gain faded
 * from 1 to g1 over n_fade steps at 0.15 s (as fs_drive fades it: the
 * voltage h.u scales with it). Writes the largest |theta_hat - theta| and
 * the largest |i_n / (gain In) - 1| over the 0.05 s from the fade on. */
static void run_fade(const fs_hfi_config *cfg, double complex i_dc, double g1, int n_fade, double In,
                     double *err_max, double *amp_max)
{
    static fs_hfi h;
    const double th = 1.0;
    FS_CHECK_EQ_INT(fs_hfi_init(&h, cfg), FS_OK, "init");
    fs_hfi_reset(&h, (float)th, 0.0f);
    scen s = {R_S, th, 0.0, 0.0, i_dc, 1, th, 0.0, 0};
    double complex psi = SL * i_dc + DL * cexp(2.0 * I * th) * conj(i_dc)
                       + U_H / (I * W_H * SINC * SINC) * cexp(I * W_H * TS), u_hist[3] = {0.0, 0.0, 0.0};
    const int k0 = N_RUN / 2;
    *err_max = *amp_max = 0.0;
    for (int k = 0; k < k0 + 500; ++k) {
        if (k >= k0) h.gain = (float)fmax(g1, 1.0 - (1.0 - g1) * (k - k0 + 1) / n_fade);
        double t = k * TS;
        double complex i = current(&s, psi, t);
        fs_hfi_step(&h, (fs_ab){(float)creal(i), (float)cimag(i)}, 0.0f);
        if (k >= k0) {
            *err_max = fmax(*err_max, fabs(fs_test_wrap(h.theta - th)));
            *amp_max = fmax(*amp_max, fabs(h.i_n / (h.gain * In) - 1.0));
        }
        u_hist[k % 3] = h.u.alpha + I * h.u.beta;
        double complex u = k >= s.delay ? u_hist[(k - s.delay) % 3] : 0.0;
        psi = plant_period(&s, psi, t, u);
    }
}


int main(void)
{
    const fs_hfi_config c0 = config();
    const double th = 1.0;
    const scen s0 = {R_S, th, 0.0, 0.0, 0.0, 1, th - 60 * DEG, 0.0, 0};
    fs_hfi_config c; scen s; result r;
    static fs_hfi h0;
    FS_CHECK_EQ_INT(fs_hfi_init(&h0, &c0), FS_OK, "init");
    double In;
    carrier(0.0, h0.cfg.w_b_p, NULL, &In);
    const double In_meas = In * cabs(srff(-2.0 * W_H, h0.cfg.w_b_p)) / (SINC * SINC);   /* i_n: also through H_p */

    /* ---- 1. the amplitude eq. (26) divides by, beside a large fundamental ----
     * The second SRFF's state holds the negative carrier and about
     * w_b_n / w_h of the fundamental as a tone near w_h: 60 A of i_q give
     * 3 A of it beside the 1.7 A carrier. The magnitude of that sum averages
     * to about the larger of the two (3.3 A here), and dividing eq. (26) by
     * it would scale the error the observer takes, and so its loop gain, by
     * 0.5: the observer's poles would move off w_o (on motulator's 2.2 kW
     * IPMSM, designed, at rated load: 1.9 times the carrier, the release of
     * the load 8.85 el.deg instead of 4.1). Required: with the leak removed
     * (cfg.leak) the carrier's own amplitude, as without current; taking
     * the leak's image (the same SRFFs on the fundamental) out of it too
     * gives that to 0.2 % here (3.28 A as fs_hfi.c stands). With the observer at w_b_n (cfg.lag) what is left of
     * the leak moves the estimate near w_h, and the frame 2 theta_hat turns
     * the 60 A by that (the rectification of fs_hfi.h's design rules): the
     * amplitude 0.4, 1.5 and 3.4 % low at 20, 40 and 60 A, the angle 0.02,
     * 0.07 and 0.17 deg; 5 % allowed, against the 88 % more of the sum. */
    for (int lag = 0; lag <= 1; ++lag) {
        c = c0; c.leak = 1; c.lag = lag;
        s = s0; s.i_dc = 60.0 * I * cexp(I * th);
        run(lag ? "i_q = 60 A, leak removed, lag" : "i_q = 60 A, leak removed", &s, &c, &r);
        printf("  averaged negative carrier %.4f A (the carrier's %.4f A)\n", r.h.i_n_avg, In_meas);
        FS_CHECK_NEAR(r.h.i_n_avg, In_meas, (lag ? 0.05 : 0.01) * In_meas, "i_q = 60 A: the carrier's amplitude, not the leak's");
        FS_CHECK_NEAR(r.mean, 0.0, 0.2 * DEG, "i_q = 60 A: lock");
    }

    /* ---- 2. a fade of the carrier beside a large fundamental ----
     * The fade adds the change of the carriers to the SRFFs' states (the
     * carriers per unit gain, from the states at gain 1): with cfg.leak
     * those units leave out the fundamental's leak the states also hold
     * (its image in leak_p, leak_n), which does not scale with the gain.
     * Taken with the units (as fs_hfi.c stands), a snapshot of the 3 A leak
     * tone beside the 1.7 A carrier is scaled with the fade: at 60 A the
     * amplitude leaves the fading carrier by 380 % and the angle by 10 deg
     * (15 with cfg.lag). Without the leak: 2 % and 0.59 deg, with cfg.lag 16 % and 1.1 deg (its observer
     * passes what is left of the leak near w_h, which the frame
     * rectifies, as in 1.); the same fade without current: 1.5 % and
     * 0.56 deg (the sampled carrier's own transient). */
    {
        double err0, amp0, err60, amp60;
        for (int lag = 0; lag <= 1; ++lag) {
            c = c0; c.leak = 1; c.lag = lag;
            run_fade(&c, 0.0, 0.5, 100, In_meas, &err0, &amp0);
            run_fade(&c, 60.0 * I * cexp(I * th), 0.5, 100, In_meas, &err60, &amp60);
            printf("fade 1 -> 0.5 over 100 steps%s: amplitude off its carrier by %.4f (no current) and %.4f (60 A); "
                   "|error| %.3f and %.3f deg\n", lag ? ", lag" : "", amp0, amp60, err0 / DEG, err60 / DEG);
            FS_CHECK(amp0 < 0.03, "fade without current: amplitude off by %.4f", amp0);
            FS_CHECK(amp60 < (lag ? 0.25 : 0.05), "fade beside 60 A: amplitude off by %.4f", amp60);
            FS_CHECK(err60 < err0 + 1.0 * DEG, "fade beside 60 A: |error| %.3f deg (%.3f without current)", err60 / DEG, err0 / DEG);
        }
    }

    return fs_test_summary("test_hfi_amplitude");
}
