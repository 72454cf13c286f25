/* x-y current control of a five-phase machine (float32, no heap).
 *
 * Nearest-four-vector PWM (fs_pwm5.h) makes the third-harmonic plane's
 * voltage zero on average, but the machine's own third-harmonic EMF (psi_f3)
 * and the dead time's x-y voltage still drive current through that plane's
 * small impedance (R, 3 w_e L_d3): losses and distortion. Here a PI pair
 * in the plane's synchronous frame d3-q3 (the Park of (x, y) by 3 theta_e,
 * where both disturbances are constant in steady state) holds the x-y
 * current at zero, with the cross-coupling and the EMF fed forward from the
 * d3-q3 model (fs_pmsm.h):
 *   u_d3 = PI(0 - i_d3) - 3 w L_q3 i_q3,
 *   u_q3 = PI(0 - i_q3) + 3 w (L_d3 i_d3 + psi_f3),
 * each PI designed as the fundamental's (fs_pi_design on R, L_d3 or L_q3 at
 * the bandwidth). The voltage is turned back by 3 theta at the middle of the
 * period it acts in and added to the nearest-four-vector duties as its
 * phase pattern, u_k = x cos(3 k g) + y sin(3 k g), which changes neither
 * the fundamental plane nor the zero sequence (fs_xyctrl_duties). Its
 * magnitude is held within u_max_frac u_dc (anti-windup on the realised one).
 */
#ifndef FS_XYCTRL_H
#define FS_XYCTRL_H

#include "fs_pi.h"
#include "fs_transforms.h"
#include "fs_types.h"

typedef struct {
    float Ts;            /* control period, s */
    float delay;         /* computation delay, periods (0 or 1) */
    float R_s, L_d3, L_q3, psi_f3;
    float bandwidth;     /* rad/s, > 0 */
    float u_max_frac;    /* the x-y voltage's limit over u_dc, (0, 0.5] */
} fs_xyctrl_config;

typedef struct {
    fs_xyctrl_config cfg;
    fs_pi pi_d3, pi_q3;
    fs_dq i3;            /* the last measured d3-q3 current, A */
    fs_ab u_xy;          /* the last x-y voltage, V */
} fs_xyctrl;

/* FS_ERR_NULL, FS_ERR_TS, FS_ERR_RS, FS_ERR_LD / FS_ERR_LQ (L_d3, L_q3 > 0),
 * FS_ERR_PSI_F (psi_f3 >= 0), FS_ERR_BANDWIDTH, FS_ERR_PARAM (delay,
 * u_max_frac), or FS_OK. */
fs_status fs_xyctrl_init(fs_xyctrl *x, const fs_xyctrl_config *cfg);
void fs_xyctrl_reset(fs_xyctrl *x);
/* One step from the five phase currents sampled now, the angle theta_e
 * and speed w_e of the controller's frame and the dc link: the x-y voltage
 * for the next interval (stationary x-y plane). */
fs_ab fs_xyctrl_step(fs_xyctrl *x, const float i_ph[5], float theta_e, float w_e, float u_dc);
/* Adds an x-y voltage to five duties as its phase pattern (clamped to [0, 1]). */
void fs_xyctrl_duties(fs_ab u_xy, float u_dc, float duty[5]);

#endif /* FS_XYCTRL_H */
