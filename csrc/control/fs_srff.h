/* Band-stop synchronous-reference-frame filter (SRFF), yang2022 Fig. 4a.
 *
 * For a complex (alpha-beta) signal, removes the component rotating at w_x:
 *   H(s) = (s - j w_x) / (s + w_b - j w_x)                         eq. (25)
 * i.e. a first-order high-pass s / (s + w_b) in the frame rotating at w_x.
 * Realised as drawn: rotate the input into the frame at theta_x, subtract a
 * first-order low-pass of bandwidth w_b there, rotate back. The input goes
 * there and back unchanged, so only the low-pass state lp is rotated back:
 * the output is x - e^{j theta_x} lp (scaled, see the discretisation).
 *
 * The caller gives theta_x each step (the integral of w_x, which may vary in
 * time): a component that follows e^{j theta_x} exactly is a constant in the
 * frame and is removed without steady error, however w_x moves.
 *
 * Discretisation: the low-pass in the frame is exact for an input held over
 * a period (pole a = exp(-w_b Ts)) and is read at mid-period, as the average
 * of its values at the start and the end of the period, which takes out the
 * half-period delay of the hold:
 *   d[k]    = x[k] - e^{j theta_x[k]} lp[k]
 *   lp[k+1] = lp[k] + (1 - a) e^{-j theta_x[k]} d[k]
 *   y[k]    = (1 + a)/2 d[k]
 * For a tone at w, with v = w - w_x, this is exactly eq. (25) with w_b and v
 * replaced by w_b' = (2/Ts) tanh(w_b Ts/2) and v' = (2/Ts) tan(v Ts/2) (the
 * bilinear image of s/(s + w_b') with the same pole): zero at w_x, unit gain
 * at the frame's Nyquist frequency, elsewhere within about
 * (w_b/|v|) ((v Ts)^2 + (w_b Ts)^2)/12 of eq. (25). Read at the start of
 * the period instead (y = d), everything passed would come out about
 * 1 + w_b Ts/2 too large (+5 % on a fundamental through the two SRFFs of
 * fs_hfi_filter at w_b Ts = 0.063). From reset, against a tone at w_x the
 * output is (1 + a)/2 a^k times the input.
 *
 * Angles: any finite theta_x works (only its cosine and sine are used, no
 * difference of successive angles), but pass it wrapped to (-pi, pi]: a float
 * angle left to grow loses resolution (ulp 1e-3 rad at 1e4 rad) and the
 * removed tone leaks through by that much.
 *
 * Bandwidth w_b: the stop band is about (w_x - w_b, w_x + w_b); the removal
 * settles with the time constant 1 / w_b; a component at w is distorted by
 * about w_b / |w - w_x| (gain and phase). w_b Ts must be <= 0.5.
 */
#ifndef FS_SRFF_H
#define FS_SRFF_H

#include "fs_transforms.h"
#include "fs_types.h"

typedef struct {
    float Ts;   /* sampling period, s */
    float w_b;  /* bandwidth of the high-pass in the rotating frame, rad/s; 0 < w_b Ts <= 0.5 */
} fs_srff_config;

typedef struct {
    fs_srff_config cfg;
    float a;    /* exp(-w_b Ts), set by init */
    float b;    /* 1 - a */
    float g;    /* (1 + a) / 2 */
    fs_dq lp;   /* low-pass state in the frame at theta_x */
} fs_srff;

/* FS_ERR_NULL, FS_ERR_TS (Ts not > 0 or not finite), FS_ERR_BANDWIDTH
 * (w_b not > 0, or w_b Ts > 0.5); on success the state is reset. */
fs_status fs_srff_init(fs_srff *f, const fs_srff_config *cfg);
/* Clears the low-pass state: the next output is (1 + a)/2 times the input. */
void fs_srff_reset(fs_srff *f);
/* One step: input x, frame angle theta_x (rad) at this sample; returns the
 * input with its component at e^{j theta_x} removed. */
fs_ab fs_srff_step(fs_srff *f, fs_ab x, float theta_x);
/* The same with the frame given as cos(theta_x), sin(theta_x), for a caller
 * that has them already. */
fs_ab fs_srff_step_cs(fs_srff *f, fs_ab x, float cos_x, float sin_x);

#endif /* FS_SRFF_H */
