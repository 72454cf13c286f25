/* Subtraction-based current filter for rotating-voltage HFI, yang2022 Fig. 4b.
 *
 * The measured current is, eq. (24), the fundamental plus a positive carrier
 * I_p e^{j(w_h t - pi/2)} plus a negative carrier
 * I_n e^{j(-w_h t + 2 theta_r + pi/2)} that holds the rotor position.
 * Two band-stop SRFFs (fs_srff.h, eq. (25)) separate them:
 *   y    = SRFF_p(i)     at theta_h                     removes the positive carrier
 *   i_f  = SRFF_n(y)     at -theta_h + 2 theta_r_hat    removes the negative carrier
 *   i_hn = y - i_f                                      the negative carrier
 * i_f goes to the current loop, i_hn to the position observer (eq. (26)).
 * theta_h is the carrier angle w_h t (positive rotation, the angle of the
 * injected voltage of eq. (22)); theta_r_hat the estimated rotor angle; both
 * wrapped to (-pi, pi] by the caller. The sum i_f + i_hn is y exactly.
 *
 * In transfer functions, with H_p, H_n the two SRFFs,
 *   i_f = H_n H_p i,   i_hn = (1 - H_n) H_p i,
 *   1 - H_n = w_b_n / (s - j w_n + w_b_n),  w_n = -w_h + 2 w_r_hat:
 * i_hn is a first-order band-pass of bandwidth w_b_n that follows
 * theta_r_hat. Hence:
 *  - a constant error in theta_r_hat changes neither output in steady
 *    state: the negative carrier keeps its true phase 2 theta_r in i_hn,
 *    which is what the observer measures;
 *  - a speed error dw passes the carrier to i_hn with w_b_n / |j 2 dw + w_b_n|
 *    and leaks the rest into i_f; the position error reaches the observer
 *    through a first-order lag of bandwidth w_b_n.
 *
 * Choosing the bandwidths (the caller sets them; w_b Ts <= 0.5 each):
 *  - wider (larger w_b): the carriers are removed faster after a change
 *    (time constants 1/w_b_p for I_p, 1/w_b_n for I_n and the position),
 *    and the stop bands (w_x - w_b, w_x + w_b) tolerate more error in w_x;
 *  - narrower: less distortion of what passes. At the fundamental
 *    (w_f = w_r in steady state), H_p and H_n sit at frame frequencies
 *    -(w_h - w_r) and +(w_h - w_r): with w_b_p = w_b_n their phase shifts
 *    cancel and i_f has gain 1 - (w_b/(w_h - w_r))^2 and no phase error;
 *    i_hn also carries the fundamental scaled by about w_b_n / (w_h - w_r)
 *    (a ripple near w_h after heterodyning, for the observer to filter);
 *    the negative carrier crosses H_p at -2 (w_h - w_r) and comes out with
 *    a phase lag of about w_b_p / (2 w_h) (eq. (25); the discretisation's
 *    frequency warping makes it a little less, see fs_srff.h): a constant
 *    position bias of about w_b_p / (4 w_h) rad (eq. (26) halves it);
 *  - the current loop's bandwidth must stay well below w_h - w_b_p, and the
 *    observer's several times below w_b_n.
 * Default rule: w_b_p = w_b_n = w_h / 10 (for w_h = 2 pi 1 kHz: 628 rad/s,
 * settling time constant 1.6 ms; i_f gain 0.99 at the fundamental; 10 % of
 * the fundamental in i_hn; observer bandwidth up to w_b_n / 5 = 125 rad/s).
 * w_b_p may go to w_h / 20 when I_p is steady (it moves only with the
 * inductances); lower w_b_n only with a slower observer.
 */
#ifndef FS_HFI_FILTER_H
#define FS_HFI_FILTER_H

#include "fs_srff.h"
#include "fs_transforms.h"
#include "fs_types.h"

typedef struct {
    float Ts;     /* sampling period, s */
    float w_b_p;  /* bandwidth of the SRFF at the positive carrier, rad/s */
    float w_b_n;  /* bandwidth of the SRFF at the negative carrier, rad/s */
} fs_hfi_filter_config;

typedef struct {
    fs_hfi_filter_config cfg;
    fs_srff srff_p;  /* at theta_h */
    fs_srff srff_n;  /* at -theta_h + 2 theta_r_hat */
    fs_srff leak_p, leak_n;  /* the same pair on the fundamental: its leak (fs_hfi_filter_step_nl) */
} fs_hfi_filter;

/* FS_ERR_NULL, FS_ERR_TS, FS_ERR_BANDWIDTH (w_b_p or w_b_n not > 0, or
 * w_b Ts > 0.5); on success the state is reset. */
fs_status fs_hfi_filter_init(fs_hfi_filter *f, const fs_hfi_filter_config *cfg);
/* Clears both SRFFs: the next step gives i_f = g_p g_n i and
 * i_hn = g_p (1 - g_n) i, g = (1 + a)/2 of each SRFF (fs_srff.h). */
void fs_hfi_filter_reset(fs_hfi_filter *f);
/* One step on the measured current i with the carrier angle theta_h and the
 * estimated rotor angle theta_r_hat (rad); writes the fundamental current
 * i_f and the negative-sequence carrier current i_hn (either may be NULL). */
void fs_hfi_filter_step(fs_hfi_filter *f, fs_ab i, float theta_h, float theta_r_hat,
                        fs_ab *i_f, fs_ab *i_hn);
/* The same with the two frames as unit phasors: e_h = e^{j theta_h} and
 * e_n = e^{j(-theta_h + 2 theta_r_hat)} (alpha = cos, beta = sin). */
void fs_hfi_filter_step_cs(fs_hfi_filter *f, fs_ab i, fs_ab e_h, fs_ab e_n, fs_ab *i_f, fs_ab *i_hn);
/* The same with the fundamental's leak taken out of i_hn (beyond the paper). i_hn carries
 * (1 - H_n) H_p of the fundamental, about w_b_n / w_h of it at standstill:
 * 0.28 A against a 0.16 A carrier at rated load on motulator's 2.2 kW IPMSM
 * (u_h 250 V, f_h 1 kHz, w_h / 20). The heterodyne turns it into a tone at
 * w_h that rides on theta_hat, and that ripple, multiplied by the leak again
 * through the reference 2 theta_hat and the second SRFF's frame, leaves a
 * load-proportional angle bias (issue 27: 0.70 / 2.02 / 4.11 el.deg at
 * 3.5 / 7 / 14 N m). The leak is predicted by the same band-pass on the
 * fundamental just separated, (1 - H_n) H_p i_f, and subtracted:
 * i_hn' = i_hn - (1 - H_n) H_p i_f. Feed-forward within the step; what is
 * left of the leak is (1 - H_n) H_p (1 - H_n H_p) of the fundamental,
 * (w_b / w_h)^2 smaller. i_f is unchanged, so i_f + i_hn' is no longer y
 * exactly. Cost: the noise i_f carries near the carrier is taken out of
 * i_hn once more (on yang2022's noisy bench the ripple grows, so fs_hfi
 * uses it only when asked: cfg.leak). The carrier's own dynamics change:
 * i_f holds the part of a carrier change the SRFF has not yet removed, and
 * the prediction takes it out again through the same band-pass, so a change
 * of the carrier reaches i_hn' through the low-pass twice (a double pole at
 * w_b_n, fs_motion_obs.h's lag = 2) instead of once; the steady carrier is
 * the same. */
void fs_hfi_filter_step_nl(fs_hfi_filter *f, fs_ab i, fs_ab e_h, fs_ab e_n, fs_ab *i_f, fs_ab *i_hn);

#endif /* FS_HFI_FILTER_H */
