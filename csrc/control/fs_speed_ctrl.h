/* Speed controller: 2DOF PI on the mechanical speed giving a torque
 * reference, designed by fs_pi_design for J dw/dt = T - B w and the
 * closed-loop bandwidth (k_t ~ alpha J, k_p ~ 2 alpha J - B, k_i ~ alpha^2 J),
 * so that w/w_ref is first order; torque limited with anti-windup.
 */
#ifndef FS_SPEED_CTRL_H
#define FS_SPEED_CTRL_H

#include "fs_pi.h"

typedef struct {
    float Ts;         /* control period, s */
    float J;          /* inertia, kg m^2 */
    float B;          /* viscous friction, N m s */
    float bandwidth;  /* rad/s */
    float T_max;      /* torque limit, N m */
    /* explicit gains of an ordinary PI (k_t = k_p), N m s/rad and N m/rad,
     * e.g. a paper's; both 0: the 2DOF design from the bandwidth */
    float k_p, k_i;
} fs_speed_ctrl_config;

typedef struct {
    fs_speed_ctrl_config cfg;
    fs_pi pi;
} fs_speed_ctrl;

fs_status fs_speed_ctrl_init(fs_speed_ctrl *sc, const fs_speed_ctrl_config *cfg);
void fs_speed_ctrl_reset(fs_speed_ctrl *sc);
/* Torque reference for mechanical speed reference and estimate, rad/s. */
/* Bumpless start: set the integral so that at speed w_m with no speed error
 * the output is T (the torque the drive makes now). */
void fs_speed_ctrl_preset(fs_speed_ctrl *sc, float w_m, float T);
float fs_speed_ctrl_step(fs_speed_ctrl *sc, float w_m_ref, float w_m);
/* Anti-windup for a limit downstream (the current circle): the last step's
 * torque T_ref was realised as T_real; the integral moves by the difference. */
void fs_speed_ctrl_realised(fs_speed_ctrl *sc, float T_ref, float T_real);

#endif /* FS_SPEED_CTRL_H */
