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
 *
 * The error through a filter (fs_motion_obs_init_lag, beyond the paper). The injection's
 * error eq. (26) is read from the negative-sequence SRFF (fs_srff.h), whose
 * low-pass in the carrier's frame delays it. With a = exp(-w_lag Ts),
 * b = 1 - a, h = 1 - b/2 and x_k = theta_k - theta_het,k (theta_het the
 * angle the heterodyne used: theta_hat of the step before), the SRFF gives
 *   lp1_{k+1} = a lp1_k + b x_k,   eps_k = (b/2) x_k + h lp1_k      (lag = 1),
 * its mid-period reading (fs_srff.h). With the fundamental's leak taken out
 * (fs_hfi_filter_step_nl, lag = 2) the carrier passes the low-pass twice:
 * the leak is predicted from the fundamental, which holds the carrier's
 * residue x - lp1 the SRFF has not yet removed, and that residue comes back
 * through the same band-pass,
 *   lp2_{k+1} = a lp2_k + b h (x_k - lp1_k),
 *   eps_k = (b/2)^2 x_k + h (1 + b/2) lp1_k - h lp2_k.
 * Taken as the error of theta_hat, as above, the filter's poles sit inside
 * the loop unaccounted for: with lag = 1 and w_o = w_lag / 5 the error's
 * slowest poles are damped at 0.59 only, and above about w_lag / 2 they ring
 * (zeta < 0.2); the double pole of lag = 2 lags twice as long. So the
 * observer knows the filter: one or two more states, the filter's images
 * f1, f2 of theta (the recursions above with theta for x), measured as
 *   m_k = eps_k + (the filter's images of theta_het) = C [theta, w, acc, f1, f2],
 *   C = [b/2, 0, 0, h] (lag 1),  [(b/2)^2, 0, 0, h (1 + b/2), -h] (lag 2),
 * and the gains put the error's poles at the triple z_o above and at a, the
 * filter's own, once or twice (they are not moved: moving them would only
 * amplify what the filter took out). With c, g, f1, f2 as above (f1, f2
 * here the model's), q = z - 1, and the predictor gain m = Phi l from the
 * characteristic polynomial of Phi - m C matched to (q + b)^lag (q + c)^3:
 *  lag 1:  m_1 = (3c^2 - c^3/2 + b (3c - g - 3c^2/2 + c^3/4) - g (3c - g)) / (b (1 - g/2)),
 *          m_4 = (3c - g - b m_1 / 2) / h,
 *          m_2 = (c^3 + 3 b c^2 - b g m_1 - b (Ts f1 / 2 + f2) m_3) / (b f1);
 *  lag 2:  with P = c^3 g - 4c^3 + 12c^2 - 12 c g + 4g^2,
 *          Q = c^3 g - 3c^3 - 3c^2 g + 12c^2 - 12c + 4g, k = (2 - g)^2:
 *          m_1 = (4 (c - g)^3 + 2 b P - b^2 Q) / (b^2 k),
 *          m_4 = (P - b Q) / (b k),  m_5 = (2 - b) P / (2 b k),
 *          m_2 = (3 b c^2 + 2c^3 - b g m_1 - b (Ts f1 + f2) m_3) / (b f1);
 *  both:   m_3 = c^3 / (Ts f1), and the filter gains l = Phi^-1 m:
 *          l_a = m_3, l_w = (m_2 - f1 m_3) / E, l_theta = m_1 - f1 l_w - f2 l_a,
 *          l_f1 = (m_4 - b l_theta) / a,  l_f2 = (m_5 - b h (l_theta - l_f1)) / a.
 * The filter's states are kept relative, without angles to wrap: r_i = the
 * filter's image of theta_het less that of the estimate (the prediction);
 * with d the predicted motion of the step,
 *   nu = eps - C_theta d + C_f1 r1 + C_f2 r2,
 *   r1' = a (r1 - l_f1 nu) - b (d + l_theta nu),
 *   r2' = a (r2 - l_f2 nu) - b h (d + l_theta nu + r1 - l_f1 nu).
 * A load ramp missing from T_ff leaves the steady error (continuous design,
 * r = w_o / w_lag) p (dT/dt / J) (1 + 3 r) / w_o^3 with lag 1, and
 * p (dT/dt / J) (1 + 6 r + 3 r^2) / w_o^3 with lag 2; w_o can come up to the
 * filter's bandwidth, where the plain observer could not: at w_o = w_lag
 * 4 / w_lag^3 and 10 / w_lag^3 per unit of p (dT/dt / J), against 125 / w_lag^3
 * for the plain observer at w_lag / 5. Limits: w_lag Ts <= 0.5, as the
 * SRFF's. */
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
    int lag;          /* the error's filter (header): 0 none, 1 the SRFF's low-pass, 2 that twice (the leak's removal) */
    float w_lag;      /* its bandwidth, rad/s (lag > 0) */
    /* designed in init */
    float k_u;        /* p / J: electrical acceleration per N m */
    float E, f1, f2;  /* sampled model (see above) */
    float z_o;        /* exp(-w_o Ts), the triple pole of the error */
    float l_theta;    /* correction gains: angle (1), */
    float l_w;        /* speed (1/s), */
    float l_a;        /* disturbance acceleration (1/s^2), */
    float l_T;        /* the same as torque, l_a / k_u (N m/rad) */
    float a_lag;      /* exp(-w_lag Ts): the error filter's pole (lag > 0) */
    float c_theta, c_f1, c_f2;   /* the measurement C of the filter's images (header) */
    float l_f1, l_f2; /* correction of the filter's images */
    float K_d, K_p, K_i;  /* continuous-time equivalents on the electrical
                             error: N m s/rad, N m/rad, N m/(rad s); informative */
    /* state */
    float theta_hat;  /* electrical angle, rad, (-pi, pi] */
    float w_hat;      /* electrical speed, rad/s */
    float T_d_hat;    /* disturbance torque, N m (minus the load torque; the
                         integral of the PID) */
    float r1, r2;     /* lag > 0: the filter's images of the angles the error was taken against,
                         less those of the estimate (rad, header) */
} fs_motion_obs;

fs_status fs_motion_obs_init(fs_motion_obs *obs, const fs_motion_obs_config *cfg);
/* The same with the error read through the injection's filter (header):
 * lag 0, 1 or 2 (else FS_ERR_PARAM), w_lag > 0 and w_lag Ts <= 0.5 with
 * lag > 0 (else FS_ERR_BANDWIDTH). */
fs_status fs_motion_obs_init_lag(fs_motion_obs *obs, const fs_motion_obs_config *cfg, int lag, float w_lag);
/* Angle (wrapped), electrical speed; the disturbance torque is cleared
 * (and the filter's image put at the estimate). */
void fs_motion_obs_reset(fs_motion_obs *obs, float theta, float w);
/* One step with the position error of theta_hat against the angle sampled
 * now (el. rad) and the torque of the period that just ended (N m). Returns
 * the new theta_hat. */
float fs_motion_obs_step(fs_motion_obs *obs, float eps, float T_ff);
/* The model alone for one step (no error to take: the caller's filters are
 * settling); with w_lag the filter's image stays at the estimate. */
float fs_motion_obs_predict(fs_motion_obs *obs, float T_ff);

#endif /* FS_MOTION_OBS_H */
