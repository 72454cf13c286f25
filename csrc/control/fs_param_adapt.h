/* Online correction of the stator resistance and the magnet flux as the
 * machine heats (float32, no heap).
 *
 * The steady-state q-axis voltage equation in the controller's frame,
 *   y = u_q - w_e L_d i_d = R_s i_q + w_e psi_f,                       (A)
 * is linear in the two unknowns. It holds to first order under an angle
 * error eps of the frame: eps turns the d-axis voltage (R i_d - w L_q i_q)
 * into q, and with the currents turned as well what is left in (A) is
 * eps w_e (L_q - L_d) i_q, about 1 % of w_e psi_f at 5 el.deg on a machine
 * whose saliency is a third of L_d. The d-axis equation is not used: eps
 * turns the back-EMF w psi_f into it, first order.
 *
 * u is the realised voltage reference (after the dead-time compensation),
 * i the sampled current; y, i_q and w_e pass the same first-order low-pass
 * (w_lp), which keeps (A) (it is linear) and removes an injection carrier,
 * the PWM ripple and the sensor noise. Every `decim` samples the normal
 * equations of the exponentially weighted least squares over T_f are
 * updated, on the regressor scaled to volts, phi = (i_q / i_max, w_e / w_e_max),
 *   S <- lambda S + phi phi^T,  b <- lambda b + phi y,  lambda = exp(-decim Ts / T_f),
 * and the estimate S^-1 b is taken only once the window has been filled
 * (T_f of learning: the first seconds of a run, a start from standstill
 * under load, would otherwise decide it alone) and while its operating points
 * separate the two unknowns: 1 - rho^2 = det S / (S11 S22) >= min_sep (the
 * speed, or the ratio of speed to current, must have changed within T_f;
 * one operating point gives one equation for two unknowns) and the mean
 * |phi|^2 >= min_level. Otherwise the last estimate is held. The estimates
 * are bounded to [0.5, 3] R_s and [0.5, 1.5] psi_f of the nominal values.
 *
 * psi_f here is what (A) sees: the magnet's flux linkage under load, which
 * cross-saturation lowers below the open-circuit value; that is the value
 * the current controller's feed-forward wants.
 */
#ifndef FS_PARAM_ADAPT_H
#define FS_PARAM_ADAPT_H

#include "fs_transforms.h"
#include "fs_types.h"

typedef struct {
    float Ts;            /* control period, s */
    float R_s, L_d, psi_f;   /* nominal (cold) machine, the estimates' start */
    float i_max;         /* A: the regressor's current scale */
    float w_e_max;       /* rad/s: the regressor's speed scale */
    float T_f;           /* s, the least squares' forgetting time (> 0) */
    float w_lp;          /* rad/s, the signals' low-pass; 0: designed, 20 rad/s (below) */
    float min_sep;       /* 1 - rho^2 needed to update; 0: designed, 0.05 */
    float min_level;     /* mean |phi|^2 needed; 0: designed, 0.01 (10 % of i_max or w_e_max) */
} fs_param_adapt_config;

typedef struct {
    fs_param_adapt_config cfg;
    int decim, k;        /* update every decim samples (1 ms); the count */
    int n_fill, n_learn; /* updates in a window (T_f), learning updates so far (up to n_fill) */
    float a_lp;          /* the low-pass' step coefficient */
    float lambda;
    float y, i_q, w;     /* low-passed signals */
    float S11, S12, S22, b1, b2;
    float R_s, psi_f;    /* the estimates */
    float sep;           /* 1 - rho^2 of the last update */
    bool updating;       /* the last update took the estimate */
} fs_param_adapt;

/* FS_ERR_NULL, FS_ERR_TS, FS_ERR_RS, FS_ERR_LD, FS_ERR_PSI_F (psi_f > 0
 * needed), FS_ERR_LIMIT (i_max, w_e_max > 0), FS_ERR_PARAM (T_f > 0 and at
 * 20 to 1e7 updates long, w_lp, min_sep, min_level >= 0, min_sep < 1), or FS_OK. */
fs_status fs_param_adapt_init(fs_param_adapt *a, const fs_param_adapt_config *cfg);
/* Back to the nominal values, the window emptied. */
void fs_param_adapt_reset(fs_param_adapt *a);
/* One sample: u the realised voltage, i the current, both in the
 * controller's frame, w_e its speed; learn: the drive runs closed loop on
 * this frame (else the filters follow but the window is not updated).
 * Returns true when the estimates changed. */
bool fs_param_adapt_step(fs_param_adapt *a, fs_dq u, fs_dq i, float w_e, bool learn);

#endif /* FS_PARAM_ADAPT_H */
