/* Luenberger-style motion observer (Lorenz type), yang2022 sec. 3, Fig. 5.
 *
 * An inertia model driven by the torque feed-forward T_ff (the commanded or
 * estimated electromagnetic torque) and corrected by a PID on the position
 * error gives the electrical angle, the speed and a disturbance (load) torque.
 *
 * Continuous-time design (mechanical domain, e_m = theta_m - theta_m_hat):
 *   d theta_m_hat/dt = w_m_hat + (K_d / J) e_m
 *   J d w_m_hat/dt   = T_ff + T_d_hat - B w_m_hat + K_p e_m
 *   d T_d_hat/dt     = K_i e_m
 * i.e. J s^2 theta_m_hat = T_ff + (K_d s + K_p + K_i / s) e_m for B = 0:
 * the PID torque of Fig. 5, its derivative part realised by correcting the
 * angle instead of differentiating e_m. With the true motion
 * J d w_m/dt = T_ff - B w_m - T_L the error obeys
 *   (J s^3 + (K_d + B) s^2 + (K_p + B K_d / J) s + K_i) e_m = -s T_L
 * and T_d_hat -> -T_L. All three poles at -w_o,
 * (s + w_o)^3 = s^3 + 3 w_o s^2 + 3 w_o^2 s + w_o^3:
 *   K_d = 3 J w_o - B,   K_p = 3 J w_o^2 - B K_d / J,   K_i = J w_o^3,
 * in N m per mechanical rad (times s, or per s). The error comes in
 * electrical rad, e_e = p e_m, so the gains on e_e are these divided by p
 * (stored below as K_d, K_p, K_i). A constant load torque, a constant
 * acceleration without feed-forward and a constant speed are all tracked
 * with zero steady error (type 3); with an exact T_ff any motion is.
 *
 * Discrete-time form (what step computes), electrical units, state
 * x = [theta, w, a_d] with a_d = (p/J) T_d the disturbance acceleration,
 * exact zero-order-hold model of J dw_m/dt = T - B w_m over Ts
 * (x = (B/J) Ts, E = exp(-x), f1 = Ts (1-E)/x, f2 = Ts^2 (x-1+E)/x^2;
 * f1 = Ts, f2 = Ts^2/2 when B = 0):
 *   predict  theta' = theta + f1 w + f2 (u + a_d),  w' = E w + f1 (u + a_d),
 *            u = (p/J) T_ff
 *   correct  x = x' + [l_theta, l_w, l_a] (theta_meas - theta')
 * The gains place the three poles of the estimation error, eig((I - l c) Phi),
 * exactly at z_o = exp(-w_o Ts), the sampled image of (s + w_o)^3. With
 * c = 1 - z_o, g = 1 - E, and the predictor gain m = Phi l:
 *   m_1 = 3c - g,  m_3 = c^3 / (f1 Ts),  m_2 = (3c^2 - g m_1 - f2 m_3) / f1,
 *   l_a = m_3,  l_w = (m_2 - f1 m_3) / E,  l_theta = m_1 - f1 l_w - f2 l_a;
 * for B = 0, l_theta = 1 - z_o^3, l_w = (3c^2 - 1.5c^3)/Ts, l_a = c^3/Ts^2,
 * i.e. 3 w_o Ts, 3 w_o^2 Ts, w_o^3 Ts for w_o Ts << 1, the K's above times
 * (p/J) Ts.
 *
 * Timing: theta_hat and w_hat are the estimates at the last step's sampling
 * instant. At the next instant the caller measures and passes the error of
 * the current theta_hat, eps = wrap(theta_meas - theta_hat) (or the
 * heterodyne error of eq. (26) halved, eps_n / 2 ~ theta - theta_hat), and
 * the torque that acted over the period that just ended (as fs_smo takes the
 * voltage). step subtracts the predicted motion over the period from eps.
 * eps must be small for a sine-type error (|w| Ts well below 1 rad).
 *
 * Choice of the bandwidth w_o: the estimate follows the measured angle up
 * to about w_o and the model (T_ff / J) above, so w_o trades the rejection
 * of angle noise and ripple (HFI carrier residue, SMO chattering, encoder
 * quantisation) against the sensitivity to model error (J_hat, T_ff,
 * unmodelled load steps: a torque step dT missing from T_ff gives the
 * angle error (dT p / J) t^2 exp(-w_o t) / 2, peak 0.27 dT p / (J w_o^2)
 * at t = 2 / w_o). As a rule, put it 3-5 times above the speed-loop
 * bandwidth (the speed estimate then adds little phase lag to that loop) and
 * well below the bandwidths of the angle sources (the SMO's PLL, the HFI
 * carrier and its SRFF). Limits: w_o Ts <= 0.5.
 */
#ifndef FS_MOTION_OBS_H
#define FS_MOTION_OBS_H

#include "fs_types.h"

typedef struct {
    float Ts;         /* sampling period, s */
    float J;          /* model inertia J_hat, kg m^2 (> 0) */
    float B;          /* model viscous friction, N m s (>= 0; 0: none) */
    int pole_pairs;   /* p (>= 1) */
    float bandwidth;  /* w_o, triple pole at -w_o, rad/s; w_o Ts <= 0.5 */
} fs_motion_obs_config;

typedef struct {
    fs_motion_obs_config cfg;
    /* designed in init */
    float k_u;        /* p / J: electrical acceleration per N m */
    float E, f1, f2;  /* sampled model (see above) */
    float z_o;        /* exp(-w_o Ts), the triple pole of the error */
    float l_theta;    /* correction gains: angle (1), */
    float l_w;        /* speed (1/s), */
    float l_a;        /* disturbance acceleration (1/s^2), */
    float l_T;        /* the same as torque, l_a / k_u (N m/rad) */
    float K_d, K_p, K_i;  /* continuous-time equivalents on the electrical
                             error: N m s/rad, N m/rad, N m/(rad s); informative */
    /* state */
    float theta_hat;  /* electrical angle, rad, (-pi, pi] */
    float w_hat;      /* electrical speed, rad/s */
    float T_d_hat;    /* disturbance torque, N m (minus the load torque; the
                         integral of the PID) */
} fs_motion_obs;

fs_status fs_motion_obs_init(fs_motion_obs *obs, const fs_motion_obs_config *cfg);
/* Angle (wrapped), electrical speed; the disturbance torque is cleared. */
void fs_motion_obs_reset(fs_motion_obs *obs, float theta, float w);
/* One step with the position error of theta_hat against the angle sampled
 * now (el. rad) and the torque of the period that just ended (N m). Returns
 * the new theta_hat. */
float fs_motion_obs_step(fs_motion_obs *obs, float eps, float T_ff);

#endif /* FS_MOTION_OBS_H */
