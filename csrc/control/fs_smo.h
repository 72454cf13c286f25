/* Extended-EMF sliding-mode observer (yang2022, sec. 2).
 *
 * A current observer on the extended-EMF model in the stationary frame,
 * eq. (4), driven by the switching function z = k sat((i_hat - i)/delta),
 * eqs. (5)-(6). The EMF estimate e_hat is z through a low-pass filter whose
 * cutoff follows the estimated speed (Fig. 1), fed back with z so that
 * e_hat + z = e on the sliding surface, eq. (10). A normalized PLL, eq. (12),
 * with gains by pole placement, eq. (13), gives angle and speed.
 *
 * Gain: eq. (18) asks k > max|e| / 2; init computes the bound for the top
 * speed and current, refuses a configured k below it (FS_ERR_SMO_GAIN) and
 * designs k = margin * bound when k is 0.
 *
 * Boundary layer: in discrete time the correction k Ts / (L_d delta) of the
 * boundary layer must not exceed 1 (or the observer chatters by itself), so
 * delta is at least k Ts / L_d.
 *
 * Lag compensation: the filter lags z by pi/4 at its cutoff (the paper
 * compensates pi/4). With e_hat fed back as in eq. (4), z itself leads e, and
 * e_hat lags e by atan(w / (2 w_c)) = atan(1/2) at w_c = w. FS_SMO_LAG_EXACT
 * compensates that lag (default); FS_SMO_LAG_PAPER compensates pi/4.
 * Timing: the model is integrated over the last period with the voltage that
 * acted in it, so the EMF is that period's mean, half a period old: the angle
 * is advanced by w Ts / 2 to the sampling instant.
 */
#ifndef FS_SMO_H
#define FS_SMO_H

#include "fs_lpf.h"
#include "fs_pll.h"
#include "fs_transforms.h"
#include "fs_types.h"

typedef enum { FS_SMO_LAG_EXACT = 0, FS_SMO_LAG_PAPER = 1 } fs_smo_lag;

typedef struct {
    float Ts;            /* s */
    float R_s, L_d, L_q, psi_f;
    float w_e_max;       /* top electrical speed for the gain bound, rad/s */
    float i_max;         /* top current for the gain bound, A; the current estimate is held within 16 i_max */
    float k;             /* switching gain, V; 0: designed as margin * bound */
    float margin;        /* >= 1 */
    float delta;         /* boundary layer, A; floored at k Ts / L_d */
    float w_c_min;       /* filter cutoff floor, rad/s */
    float bw_pll;        /* PLL double pole, rad/s */
    float w_valid;       /* |w_hat| below this: not valid, rad/s (el.) */
    int lag;             /* fs_smo_lag */
    int dir_external;    /* 1: the direction the PLL error assumes is the caller's (fs_smo_set_dir) */
} fs_smo_config;

typedef struct {
    fs_smo_config cfg;
    float k, delta;      /* designed */
    float k_bound;       /* eq. (18) for w_e_max, i_max */
    float i_hat_max;     /* the current estimate's bound, 16 i_max (fs_smo_step) */
    fs_ab i_hat;         /* estimated current */
    fs_ab z;             /* switching function output */
    fs_lpf lpf;          /* e_hat = lpf.y */
    fs_pll pll;
    float theta;         /* estimated angle at the sampling instant, rad */
    float w;             /* estimated electrical speed, rad/s */
    bool valid;
    float dir;           /* direction of rotation the PLL error assumes: +1, -1 (hysteresis at w_valid) */
    float r_i;           /* max |current error| over delta at the last step: <= 1 while sliding */
    float eps;           /* the last normalized PLL error, sin(theta - theta_pll) */
    float e_mag;         /* |filtered EMF|, V: about |w| psi_f / sqrt 2 behind the filter when it tracks */
} fs_smo;

fs_status fs_smo_init(fs_smo *o, const fs_smo_config *cfg);
void fs_smo_reset(fs_smo *o, float theta, float w);
/* With dir_external: the direction of rotation from an estimate the caller
 * trusts at low speed (the sign of w; w = 0 keeps it). In the blend the
 * injection side knows the direction long before the back-EMF does, and an
 * observer that took it from its own speed at standstill could lock pi off. */
void fs_smo_set_dir(fs_smo *o, float w);
/* One step: i is the current sampled now, u the stationary voltage that
 * acted during the period that ended now. Returns the angle. */
float fs_smo_step(fs_smo *o, fs_ab i, fs_ab u);

#endif /* FS_SMO_H */
