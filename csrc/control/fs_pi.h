/* Two-degree-of-freedom PI controller with anti-windup.
 *
 *   u = k_t r - k_p y + I,    I[k+1] = I[k] + Ts k_i (r - y) + (u_real - u)
 *
 * The last term is back-calculation with unit gain: when the actuator realises
 * u_real instead of u, the integral is moved so that the next output starts
 * from what was realised (no windup). With k_t = k_p it is the ordinary PI.
 */
#ifndef FS_PI_H
#define FS_PI_H

#include "fs_types.h"

typedef struct {
    float Ts;     /* sampling period, s */
    float k_t;    /* reference gain */
    float k_p;    /* proportional gain on the measurement */
    float k_i;    /* integral gain */
    float u_max;  /* output limit, symmetric; <= 0 means none */
} fs_pi_config;

typedef struct {
    fs_pi_config cfg;
    float k_i_Ts; /* Ts k_i, formed once in init as the update formed it */
    float integ;  /* integral state I */
} fs_pi;

fs_status fs_pi_init(fs_pi *pi, const fs_pi_config *cfg);
/* Gains for the plant L dx/dt = u - R x sampled with period Ts, placed so
 * that the sampled closed loop is exactly first order, x/r = (1-p)/(z-p)
 * with p = exp(-alpha Ts), and the disturbance poles are both at p:
 *   a = exp(-R Ts/L), b = (1-a)/R (Ts/L if R = 0),
 *   k_t = (1-p)/b,  k_p = (1+a-2p)/b,  k_i = (1-p)^2/(b Ts).
 * For small alpha Ts these are k_t = alpha L, k_p = 2 alpha L - R,
 * k_i = alpha^2 L (Harnefors' continuous-time 2DOF design). */
fs_status fs_pi_design(fs_pi_config *cfg, float Ts, float L, float R, float alpha, float u_max);
/* fs_pi_design, then fs_pi_init with its gains: the status of the first
 * that fails (the PI untouched where the design does). */
fs_status fs_pi_design_init(fs_pi *pi, float Ts, float L, float R, float alpha, float u_max);
void fs_pi_reset(fs_pi *pi);
/* Unlimited output for (r, y); does not change the state. */
float fs_pi_output(const fs_pi *pi, float ref, float meas);
/* Advance the integral given the unlimited output u and the realised u_real. */
void fs_pi_update(fs_pi *pi, float ref, float meas, float u, float u_real);
/* Output limited to +-u_max, and the update with that limited value. */
float fs_pi_step(fs_pi *pi, float ref, float meas);

#endif /* FS_PI_H */
