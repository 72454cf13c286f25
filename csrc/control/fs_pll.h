/* Phase-locked loop / angle tracker: a PI on the angle error gives the speed,
 * its integral the angle. With error = sin(theta - theta_hat) or its
 * small-angle value, the closed loop is eq. (13) of yang2022:
 *   G(s) = (K_p s + K_i) / (s^2 + K_p s + K_i),
 * with both poles placed at -bandwidth: K_p = 2 w_b, K_i = w_b^2.
 * The speed estimate is the integral path (speed tracks without steady
 * error and without the proportional path's noise).
 */
#ifndef FS_PLL_H
#define FS_PLL_H

#include "fs_types.h"

typedef struct {
    float Ts;         /* sampling period, s */
    float bandwidth;  /* double pole, rad/s */
    float w_max;      /* speed clamp, rad/s (electrical); <= 0: none */
} fs_pll_config;

typedef struct {
    fs_pll_config cfg;
    float k_p, k_i;   /* designed in init */
    float theta;      /* angle estimate, rad, wrapped to (-pi, pi] */
    float w;          /* speed estimate, rad/s */
    float integ;      /* integral of k_i * error */
} fs_pll;

fs_status fs_pll_init(fs_pll *pll, const fs_pll_config *cfg);
void fs_pll_reset(fs_pll *pll, float theta, float w);
/* One step with the angle error (rad, or its sine); returns the new angle. */
float fs_pll_step(fs_pll *pll, float err);

#endif /* FS_PLL_H */
