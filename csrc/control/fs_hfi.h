/* Rotating-voltage HF injection estimator, yang2022 sec. 3 (Figs. 3-5).
 *
 * Each step it
 *  1. separates the sampled current into the fundamental i_f (for the current
 *     loop) and the negative-sequence carrier i_hn (fs_hfi_filter, Fig. 4b),
 *     with cfg.leak the fundamental's leak taken out of the latter
 *     (fs_hfi_filter_step_nl, beyond the paper: it leaves a
 *     load-proportional bias, 4.1 el.deg at rated load on motulator's
 *     2.2 kW IPMSM, and forces narrow filters);
 *  2. heterodynes i_hn against the carrier expected at the estimated angle,
 *     eq. (26): eps_n = sin(2 (theta_r - theta_hat));
 *  3. runs the Luenberger motion observer (fs_motion_obs, Fig. 5) on
 *     eps_n / 2 with the torque feed-forward;
 *  4. gives the injection voltage u_h for the next update, eq. (22).
 *
 * Timing (what makes the angle unbiased, not only consistent):
 *  - theta_h is the carrier angle w_h t at the sampling instant of this step;
 *    the filter and the heterodyne use it as it is. The voltage computed now
 *    acts over [t + delay Ts, t + (delay + 1) Ts]; it is given the angle at
 *    the middle of that interval and the amplitude u_h / sinc(x),
 *    x = w_h Ts / 2: the held staircase's component at w_h is then exactly
 *    eq. (22), u_h e^{j w_h t}, in amplitude and phase. At the samples the
 *    carrier currents keep eq. (24)'s phases; their amplitudes are
 *    1 / sinc^2(x) larger (3.4 % at 10 samples per period: the staircase's
 *    other harmonics alias onto the carrier).
 *  - The first SRFF (at +w_h) shifts the negative carrier, 2 w_h away from its
 *    stop band, by the angle phi_p = atan(w_b' / v') (fs_srff.h: w_b', v' the
 *    bilinear images of w_b and 2 w_h): a bias of phi_p / 2 (0.6 el.deg at
 *    the default bandwidth w_h / 20), taken out in the heterodyne's
 *    reference: e^{j(-theta_h + 2 theta_hat + pi/2 - phi_p - phi_r)}.
 *  - eq. (23) neglects the resistance. With it, the carrier responses of
 *    u = R i + d psi/dt, psi = SigmaL i + DeltaL e^{j 2 theta} conj(i), are
 *    I_n e^{j(-w_h t + 2 theta + pi/2 - phi_r)},
 *      phi_r = atan2(2 R w_h SigmaL, w_h^2 (SigmaL^2 - DeltaL^2) - R^2),
 *    a bias of phi_r / 2 (4.3 el.deg on the yang2022 machine at 1 kHz, where
 *    R / (w_h SigmaL) = 0.074), also taken out in the reference. With the
 *    held voltage the resistive drops of the aliased harmonics add up, to
 *    first order, to R x cot(x) at the samples: R is replaced by that
 *    (0.14 el.deg of the 4.3 at 10 samples per period).
 *
 * Normalisation of eq. (26): by the negative carrier's amplitude I_hn, taken
 * from the second SRFF's state (the carrier in its own frame, low-pass
 * filtered) and averaged further with the cutoff w_b_n / 4, starting from the
 * amplitude the machine parameters give. Not by the instantaneous |i_hn|,
 * nor by the SRFF's state alone: both carry about w_b_n / w_h of the
 * fundamental current as a ripple near w_h (at 25 A as much as the 1.7 A
 * carrier of the yang2022 machine), and dividing by a magnitude that swings
 * with it rectifies that ripple into an angle bias (2 el.deg at 25 A).
 * Divided by the steady amplitude the ripple stays a zero-mean tone near w_h
 * for the observer to filter.
 *
 * Cross-saturation compensation (beyond the paper): a cross-saturated machine
 * has its HF saliency axis at theta_r + delta(i_q), and the estimator locks
 * there. Given delta against i_q (fs_xcomp.h: a table measured offline, e.g.
 * with the encoder in the loop, or a fitted cubic), the negative carrier is
 * expected at 2 (theta_hat + delta(i_q)) - theta_h: the second SRFF's frame
 * is put there (the heterodyne's reference with it), and theta_hat converges
 * to theta_r. Where delta enters matters. The axis turns with the current at
 * once, and the negative carrier reports the turn through the second SRFF's
 * low-pass at w_b_n, twice with cfg.leak (fs_hfi_filter.h); delta in that
 * SRFF's frame passes the same low-pass, so that the two cancel at every
 * instant, not only in steady state. Turning the heterodyne's reference
 * alone, after the filter (as before), led the reported axis by 1 / w_b_n
 * (2 / w_b_n with cfg.leak): every change of i_q drove the observer with an
 * error of delta' di_q that decays with the filter, and in speed control the
 * loop's own i_q closed a loop through it. On the yang2022 machine holding
 * rated torque at standstill with the leak removed and a table measured so,
 * that loop limit-cycled at 35 Hz: +-15 el.deg, i_q 13..63 A, the rotor
 * rolling back to -42 rpm (blended: +-29 el.deg, -89 rpm), at the paper's
 * observer's resonance with the double lag it does not model (|T| 2.7 near
 * 20 Hz, 171 deg of lag at 35 Hz; with the paper's filter 1.55 at most,
 * which is why keeping the leak hid it). With delta in the frame the same
 * run holds within +-2.3 el.deg; blended, where the blend's observer
 * filters that observer's angle again, it still rings at +-12: the paper's
 * observer and the leak's removal do not go together (scenario.py defaults
 * the removal with cfg.lag, whose observer is designed for the double lag:
 * +-0.8 el.deg either way, checks.py warns of the pair). test_hfi.c's i_q
 * step (20 A, the axis turning 10 deg with it) moved the estimate 6.8, 12.1
 * and 27.6 el.deg beyond the step's own transient (paper's filter and
 * observer, leak removed, and with cfg.lag); now 1.0, 0.9 and 1.8. i_q is
 * the fundamental current's q component in the estimated frame averaged
 * over the last carrier period (FS_HFI_IQ_MAX samples at most): a saturating
 * machine's current carries harmonics of the carrier (the iron's response
 * to it; 0.9 A at 2 w_h on the yang2022 machine at 38 A), which would turn
 * the frame at those frequencies and mix the positive carrier, six times
 * the negative, into the negative's band (with cfg.lag at 38 A: the error
 * 1.7 el.deg rms, 0.2 with the average). The average takes out every
 * harmonic of the carrier at standstill and delays delta by half a carrier
 * period (the 1.0-1.8 el.deg above).
 *
 * Design rules (see fs_hfi_filter.h and fs_motion_obs.h): w_b_p = w_b_n =
 * w_h / 20. Equal, so that their phase shifts on the fundamental cancel
 * (with w_h / 10 and w_h / 20 the current loop would see the fundamental
 * 2.9 el.deg ahead); w_h / 20 rather than the filter's w_h / 10, so that the
 * fundamental's leak into i_hn halves (the carriers settle in 3.2 ms, still
 * far faster than the observer). Observer bandwidth w_b_n / 5. 0 in the
 * config selects these.
 *
 * The observer with the filters' lag in its loop (cfg.lag, beyond the
 * paper): eq. (26)'s error is read from the second SRFF's low-pass, a
 * first-order lag at w_b_n (twice with cfg.leak: the leak's prediction takes
 * the carrier's unremoved residue back out through the same band-pass,
 * fs_hfi_filter.h), which the paper's observer takes as the error itself,
 * hence its bandwidth five times below (with one such pole its slowest poles
 * are damped at 0.59; with two, less). A load the drive does not know
 * reaches the estimate as an error of about p (dT/dt / J) / w_o^3 while it
 * ramps (0.27 p dT / (J w_o^2) at the peak after a step), so w_o sets the
 * error at standstill under an unknown load. With cfg.lag the motion
 * observer is designed with the filter in its loop (fs_motion_obs.h: its
 * triple pole at w_o, the filter's pole, once or twice, kept where it is),
 * and the default bandwidth is FS_HFI_OBS_PER_FILTER_LAG x w_b_n: the triple
 * pole at the filter's bandwidth, as fast as the filter lets the angle
 * through (beyond it the observer would undo the filter: its ripple and
 * noise). A load ramp then lags 12.5 times less than with the paper's
 * observer (10 / w_b_n^3 against 125 / w_b_n^3 per unit of p (dT/dt) / J,
 * with the leak's removal; fs_motion_obs.h). On the machine zoo (fullspeed.model.zoo, scenario beyond-zoo) every
 * ratio from 0.4 to 1.5 keeps the 50 saturating machines within 15 el.deg;
 * on motulator's 2.2 kW IPMSM the load release's error falls from 10.6
 * el.deg at 0.4 to 3.7 at 1 and 2.3 at 2 while the mean under rated load at
 * standstill grows from 0.05 to 0.26 and 0.9 el.deg (the ripple the faster
 * observer passes and the heterodyne rectifies). Resumed after a stop
 * (fs_drive.c) it starts afresh: its gains would take the stale carriers'
 * angle.
 *
 * The speed, with cfg.lag, comes from a second motion observer (obs_w) at
 * the paper's rule, w_o_blend = w_b_n / 5, on the first one's angle, with
 * the same torque feed-forward: theta is the fast observer's, w the slow
 * one's. The fast observer passes the angle the carrier reports up to w_b_n
 * (its |T| 1.9 at 35-50 Hz on the defaults): the speed it implies is that
 * angle's every move times its frequency. On a cross-saturated machine the
 * reported angle moves with the current, faster than the table can say (the
 * cross inductance's rate of change adds a carrier response about 90 deg
 * ahead: on the yang2022 machine at 38 A 0.44 el.deg/A at 10 Hz and 0.75
 * at 70 Hz, against the table's 0.37 static; with the table 0.12 and 0.74), so
 * a speed loop on the fast speed closes a loop through the machine, i_q ->
 * reported angle -> speed -> i_q, of gain K_p D w |T(jw)| / p: 5 at 70 Hz
 * with that machine's bw_speed of 100 rad/s, 1.6 still at 30 rad/s.
 * Holding rated torque at standstill with its table, on the fast speed the
 * rotor ran away (-277 rpm; at 30 rad/s it held, ringing +-3.5 el.deg), and
 * yang2022-hfi-ramp's error went from the paper observer's 1.9 to 23.2
 * el.deg; on the slow observer's speed +-0.8 el.deg and 2.9 el.deg, as
 * blended (whose speed is the blend's observer's, at the same rule). The
 * magnet polarity detection reads that speed too (fs_polarity.h: the
 * rotor's motion under the pulses): on the fast one, yang2022-blend-iqstep's
 * (200 rpm, held) took the pulses' turn of the axis for motion and refused,
 * or not, by a millisecond of t_lock (0.060 s refused, 0.061 s decided);
 * on the slow one both decide, margin 3.3.
 */
#ifndef FS_HFI_H
#define FS_HFI_H

#include "fs_hfi_filter.h"
#include "fs_motion_obs.h"
#include "fs_transforms.h"
#include "fs_types.h"
#include "fs_xcomp.h"

/* The observer's default bandwidth per w_b_n: the paper's rule, and with the
 * filter's lag in the loop (header). */
#define FS_HFI_OBS_PER_FILTER 0.2f
#define FS_HFI_OBS_PER_FILTER_LAG 1.0f
#define FS_HFI_IQ_MAX 40

typedef struct {
    float Ts;                  /* sampling period, s */
    float delay;               /* computation delay, control periods (0..2) */
    float u_h;                 /* injected amplitude, V (> 0), eq. (22) */
    float w_h;                 /* injected frequency, rad/s; more than 4 samples per period: w_h <= fs_hfi_w_h_max(Ts) */
    float R_s;                 /* the controller's resistance, ohm (>= 0) */
    float L_d, L_q;            /* the controller's inductances: saliency needed, |L_q - L_d| > 1 % */
    float w_b_p, w_b_n;        /* filter bandwidths, rad/s (0: w_h / 20 each); w_b Ts <= 0.5, w_b_n Ts >= 1e-4 */
    fs_motion_obs_config obs;  /* Ts is taken from above; bandwidth 0: w_b_n / 5, with lag FS_HFI_OBS_PER_FILTER_LAG w_b_n */
    fs_xcomp_config xcomp;     /* cross-saturation compensation (all zero: off) */
    int leak;                  /* 1: the fundamental's leak taken out of i_hn (fs_hfi_filter_step_nl); 0: the paper's filter */
    int lag;                   /* 1: the motion observer designed with the second SRFF's lag in its loop (header); 0: the paper's */
} fs_hfi_config;

typedef struct {
    fs_hfi_config cfg;         /* with the defaults filled in */
    fs_hfi_filter filt;
    fs_motion_obs obs;
    fs_motion_obs obs_w;       /* with cfg.lag: the speed's observer (header), at w_o_blend on the angle of obs */
    float dtheta_h;            /* w_h Ts */
    float theta_u;             /* w_h Ts (delay + 1/2): voltage angle ahead of the sample */
    float u_amp;               /* u_h / sinc(w_h Ts / 2) */
    float phi_ref;             /* pi/2 - phi_p - phi_r: the heterodyne reference's fixed rotation */
    fs_ab rot_u, rot_ref;      /* e^{j theta_u}, e^{j phi_ref}: the carrier phasor turned by them */
    fs_ab rot_h;               /* e^{j w_h Ts}: the carrier's turn in a step */
    float i_n_design;          /* the negative carrier's amplitude from the parameters, A */
    float k_avg;               /* 1 - exp(-w_b_n Ts / 4): the amplitude's averaging */
    int n_settle;              /* steps the filters take to settle, 3 / (w_b_n Ts) */
    float k_follow;            /* 1 - exp(-w_b_n Ts): fs_hfi_follow's step */
    float w_o_blend;           /* the bandwidth of the observer the speed comes from, rad/s: cfg.obs.bandwidth, with
                                  lag the paper's rule (obs_w's, and the blend's by default: it filters the back-EMF
                                  observer's angle in the band, where a faster one passes that angle's noise to the
                                  speed loop; fs_drive.c) */
    /* state */
    int k_settle;              /* steps left before the error is used (after reset; a fade-in: fs_hfi_fade_in) */
    float gain;                /* the caller's scale on the injected amplitude, 0..1 (reset: 1);
                                  a change adds the carriers' change to the filters' states, so
                                  that a fading carrier is followed, not left behind by their lag */
    float gain_prev;           /* the gain of the last step: a caller that pauses the estimator at
                                  gain 0 (no steps) and resumes at the same gain finds the filters
                                  as it left them, carrier angle included */
    fs_dq unit_p, unit_n;      /* the carriers per unit gain: the states at gain 1 (with cfg.leak less the leak's image),
                                  taken as the gain leaves 1 (0 until then) */
    float theta_h;             /* carrier angle at the next sampling instant, (-pi, pi] */
    fs_ab e_h;                 /* e^{j theta_h}: turned by rot_h each step, from fs_cis once per n_iq steps */
    int k_h;                   /* steps since e_h was formed from theta_h */
    /* outputs of the last step */
    fs_ab i_f;                 /* fundamental current, A */
    fs_ab i_hn;                /* negative-sequence carrier current, A */
    fs_ab ref;                 /* its expected direction at the estimate, eq. (26) (the last step's) */
    float i_p, i_n;            /* positive and negative carrier amplitudes (the SRFFs' states), A */
    float i_n_avg;             /* the averaged negative amplitude eq. (26) divides by, A */
    float eps;                 /* eps_n / 2, rad: the angle error seen */
    float delta;               /* the compensation used, rad */
    float i_q;                 /* the fundamental's q current it is taken at: over the last carrier period (header), A */
    float iq_sum;              /* the running sum over that period */
    float iq_buf[FS_HFI_IQ_MAX];
    int n_iq, k_iq;            /* samples a carrier period (at most FS_HFI_IQ_MAX); the buffer's next slot */
    float inv_n_iq;            /* 1 / n_iq */
    float theta, w;            /* the observer's angle (rad) and electrical speed (rad/s; with lag obs_w's) */
    fs_ab u;                   /* injection voltage for the next update, V */
} fs_hfi;

/* The carrier's limit, the one rule for C and the scenario's check: more
 * than 4 samples per carrier period, w_h Ts < pi/2 as float computes it (at
 * pi/2 the first SRFF's phase, atan(w_b' / v') with v' = (2/Ts) tan(w_h Ts),
 * and the heterodyne's reference are undefined; float32 rounds w_h Ts for
 * f_h = fs/4 above pi/2). Returns the largest w_h (rad/s) init accepts for
 * Ts, or 0 for a Ts that is not finite and > 0. */
float fs_hfi_w_h_max(float Ts);
/* The longest sampling period fs_hfi takes, s: no drive's, it bounds the
 * carrier limit's float search (fs_hfi_w_h_max returns 0 beyond it, where
 * (pi / 2) / Ts 2^-24 would be subnormal and the search would not end) */
#define FS_HFI_TS_MAX 1e30f
/* FS_ERR_NULL, FS_ERR_TS, FS_ERR_PARAM (u_h, delay, table), FS_ERR_BANDWIDTH
 * (w_h above the limit, filter or observer bandwidths), FS_ERR_SALIENCY
 * (L_d = L_q: nothing to track), and the motion observer's. Resets. */
fs_status fs_hfi_init(fs_hfi *h, const fs_hfi_config *cfg);
/* Observer at angle theta (rad) and speed w (el. rad/s), filters cleared,
 * carrier at angle 0. For the filters' settling time, 3 / w_b_n, the
 * observer runs on its model alone (the error is taken as 0). */
void fs_hfi_reset(fs_hfi *h, float theta, float w);
/* The resistance the carrier's phase compensation assumes (an online
 * estimate, fs_param_adapt.h); a value not finite or < 0 is ignored. */
void fs_hfi_set_resistance(fs_hfi *h, float R_s);
/* As fs_hfi_reset, at gain 0 for a fade-in, keeping the carriers per unit
 * gain (unit_p, unit_n: the machine's at the operating point where the
 * injection last ran at full gain), so that the fade adds them to the
 * cleared filters as it goes. Cleared with the filters, the carrier ramped
 * in over n_settle left the filters behind by a third of it at the ramp's
 * end (its slope times their time constant), and the fundamental the
 * back-EMF observer reads carried that residue: on B-REAL's scenario the
 * zoo's saturating machines 0, 2 and 4, reversed through the band by their
 * load, reached 4.8, 15.3 and 8.1 el.deg, 3.1, 6.1 and 6.1 with the
 * carriers kept (bench: reproduce/papers/mapid.py's true-map runs). */
void fs_hfi_restart(fs_hfi *h, float theta, float w);
/* From gain 0, the carrier ramped in over n_settle (the step's gain's
 * rate), and the error first read once the filters have settled on the
 * whole carrier, n_settle after the ramp (2 n_settle in all): ramped in,
 * the carrier leaves them behind by a third of it at the ramp's end (its
 * slope times their time constant). Read there, the positive carrier's
 * image that the negative sequence's filter held turned the Baldor
 * PM-SyRM's estimate by 12 el.deg at its first corrections (B-REAL's
 * reversal through 100 rpm, a resume), and SyR-e's THOR's by 17 el.deg at
 * standstill with no current asked (the drive's start). fs_hfi_restart
 * starts with it; after fs_hfi_reset, a start from standstill. */
void fs_hfi_fade_in(fs_hfi *h);
/* Move the observer only (polarity flip, re-sync), keeping filters and carrier. */
void fs_hfi_set_angle(fs_hfi *h, float theta, float w);
/* Move the observer toward theta (rad) at the filters' bandwidth w_b_n, its
 * speed set to w (el. rad/s; as set_angle, the load cleared): the filters
 * work in the frames e^{j theta_hat} and e^{j 2 theta_hat} (the negative
 * carrier's and the leak's), and an angle taken whole each step from a
 * noisy source turns those frames by its noise. The fundamental's image in
 * the negative sequence's band is then turned with them: on the 2004
 * Prius MG2 a back-EMF observer's angle with 0.57 el.deg rms of step-to-step
 * noise turned 122 A by it, about 2.4 A in the band beside a 2.42 A carrier,
 * which the leak's removal (the same frames) does not take out. Followed
 * at w_b_n the frames move no faster than the filters pass, the noise above
 * it is attenuated as w_b_n over its frequency, and an offset is taken up
 * within n_settle (3 / w_b_n, 95 %); the prediction at w (the observer's
 * own model) carries the motion, so that a steady speed leaves no lag. */
void fs_hfi_follow(fs_hfi *h, float theta, float w);
/* The load both observers carry (N m; fs_motion_obs.h's T_d_hat): set_angle
 * and reset clear it. */
void fs_hfi_set_load(fs_hfi *h, float T_d);
/* The angle from the estimate to the saliency's axis, el. rad in (-pi/2, pi/2]:
 * half the angle of the negative-sequence carrier from its expected
 * direction (eq. (26) in full, atan2 for the small-angle eps), modulo pi
 * (the axis, not its polarity). Meaningful once the filters have settled. */
float fs_hfi_axis_error(const fs_hfi *h);
/* One step on the sampled current with the torque that acted over the
 * period that just ended (N m). Returns the estimated angle. */
float fs_hfi_step(fs_hfi *h, fs_ab i, float T_ff);

#endif /* FS_HFI_H */
