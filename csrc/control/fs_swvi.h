/* Square-wave HF voltage injection with filterless processing, yu2022.
 *
 * Injection, eq. (4): +-u_h on the estimated d axis, a square wave of period
 * T_h = 4 Ts: two control periods at +u_h, two at -u_h. With the carrier's
 * edges at the odd samples, the HF current is a triangle through zero at the
 * even samples and at its peaks at the odd ones (Fig. 3; sec. 2.2: four
 * samples per period, the fundamental voltage updated at twice the
 * injection frequency, i.e. at the even samples only).
 *
 * Filterless processing, eq. (8): at an even sample k the current is the
 * fundamental's (the triangle crosses zero); the HF current at the peak k-1
 * is i(k-1) - (i(k-2) + i(k)) / 2, exact while the fundamental rises
 * linearly over the window (k-2, k), i.e. while its voltage is held there
 * (the caller's duty: the drive changes the fundamental voltage only at
 * window boundaries). Signed by the carrier half before the peak it is the
 * response's amplitude, eq. (5): I_dh = u_h Ts / L_d and
 *   I_qh = (Ts u_h / (2 L_d L_q)) (L_q - L_d) sin(2 theta_err)
 * with theta_err = theta_r - theta_hat; normalised, eqs. (6)-(7), with
 * K_norm = 4 L_d L_q / (T_h u_h (L_q - L_d)), f = K_norm I_qh =
 * sin(2 theta_err) / 2, the PLL of Fig. 1 (fs_pll) takes it as its error.
 * The paper's gains K_p = 115, K_i = 3306 are fs_pll's design
 * (k_p = 2 w_b, k_i = w_b^2) at w_b = 57.5 rad/s.
 *
 * Time sequences, sec. 3.2 (the text is garbled between eqs. (10) and (16);
 * this is the reconstruction, from eqs. (9), (10), (16)-(18)). The voltage
 * computed at step k acts over (k + delay, k + delay + 1) at the PLL's
 * angle theta_k of that step (eq. (9): over (m-1, m) the angle theta_{m-2}).
 *  CONVENTIONAL (Fig. 5): each sample is turned into the estimated frame
 *    with the angle of the previous step, theta_{k-1} (eq. (10)'s current at
 *    m in the frame theta_{m-1}), and eq. (8) is taken on the d-q samples.
 *    The peak's frame is then half a step ahead of the mean direction of
 *    the voltage that drove it, so the large common-mode response
 *    L_Sigma = L_d + L_q leaks into the q current: with L_Sigma / L_dif =
 *    13 on the yu2022 machine the estimate lags (theta_err > 0, growing with
 *    speed), Fig. 14a.
 *  OPTIMIZED (Fig. 6): eq. (8) on the stationary samples, and the HF current
 *    turned into the frame of the voltage that drove it, the mean of the two
 *    injection angles of the window, theta_{k-2} + w Ts / 2 (eq. (16)). The
 *    common-mode term cancels exactly; the PLL aligns the injection with
 *    the rotor at the peak, the middle of the window, 1.5 Ts after the
 *    angle was computed (delay 1): the estimate leads, theta_err =
 *    -1.5 w_e Ts in steady state, eq. (18).
 *
 * Cross-saturation, sec. 3.3: the PLL locks on the HF saliency axis,
 * theta_r + delta(i_q), delta = -phi_dq / 2 (eq. (21)) with phi_dq =
 * atan(2 L_dq / (L_q - L_d)): eq. (20)'s L_dif is the half difference, as in
 * its source [26], not eq. (3)'s L_q - L_d (csrc/tests/test_swvi.c checks
 * the exact lock angle on a model with L_dq). With a compensation
 * (fs_xcomp.h: a table measured offline or eq. (22)'s cubic) the output
 * angle is theta_pll - delta(i_q), i_q the fundamental q current in the
 * output frame. The injection stays on the PLL's axis, where the q response
 * is zero.
 */
#ifndef FS_SWVI_H
#define FS_SWVI_H

#include "fs_pll.h"
#include "fs_transforms.h"
#include "fs_types.h"
#include "fs_xcomp.h"

typedef enum {
    FS_SWVI_CONVENTIONAL = 0,  /* Fig. 5: samples in the previous step's frame */
    FS_SWVI_OPTIMIZED = 1      /* Fig. 6: the HF current in its voltage's frame, eq. (16) */
} fs_swvi_sequence;

typedef struct {
    float Ts;                  /* sampling period, s; the carrier period is 4 Ts */
    int delay;                 /* computation delay, control periods: 0 or 1 */
    float u_h;                 /* injected amplitude, V (> 0), eq. (4) */
    float L_d, L_q;            /* the controller's inductances (saliency needed), eq. (7) */
    float bandwidth;           /* PLL double pole, rad/s (the paper: 57.5, K_p = 115, K_i = 3306) */
    float w_max;               /* PLL speed clamp, el. rad/s (0: none) */
    int sequence;              /* fs_swvi_sequence */
    fs_xcomp_config xcomp;     /* cross-saturation compensation (all zero: off) */
    bool carrier_off;          /* comparison runs: the same timing without the carrier (no estimate) */
} fs_swvi_config;

typedef struct {
    fs_swvi_config cfg;
    fs_pll pll;                /* Fig. 1: the angle the carrier is injected on */
    float k_norm;              /* eq. (7), 1/A */
    /* state */
    long long k;               /* samples since reset */
    fs_ab i_ab[4];             /* the last samples, stationary, by k mod 4 */
    fs_dq i_dq[4];             /* the same in the previous step's frame (conventional) */
    float theta_u[4];          /* injection angle of the interval starting at sample j, by j mod 4 */
    /* outputs of the last step */
    bool ff_fresh;             /* this sample is a zero crossing: i_f is new, the loops may run */
    fs_ab i_f;                 /* fundamental current of the last zero crossing, eq. (8), A */
    fs_dq i_h;                 /* HF current at the last peak, signed by its carrier half, eq. (8), A */
    float eps;                 /* the PLL's error K_norm I_qh, eq. (6), rad */
    float delta;               /* the compensation used, rad */
    float theta, w;            /* rotor angle (compensated, rad) and electrical speed (rad/s): the
                                  PLL's PI output of Fig. 1, k_p eps + integral, whose zero keeps
                                  the lag small at a speed loop's crossover */
    fs_ab u;                   /* injection voltage for the interval starting at k + delay, V */
} fs_swvi;

/* FS_ERR_NULL, FS_ERR_TS, FS_ERR_PARAM (u_h, delay, sequence, xcomp),
 * FS_ERR_SALIENCY (|L_q - L_d| <= 1 %), FS_ERR_LD/LQ, FS_ERR_BANDWIDTH.
 * Resets at angle 0. */
fs_status fs_swvi_init(fs_swvi *s, const fs_swvi_config *cfg);
/* PLL at theta (rad) and speed w (el. rad/s); the carrier restarts with a
 * half-length first half so that the triangle has no offset. */
void fs_swvi_reset(fs_swvi *s, float theta, float w);
/* One step on the sampled stationary current. Returns the angle. */
float fs_swvi_step(fs_swvi *s, fs_ab i);

#endif /* FS_SWVI_H */
