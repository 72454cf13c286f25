/* Three-phase PMSM with its mechanics and load (double), for simulation.
 *
 * Electrical states are the stator flux linkages in rotor coordinates:
 *   dpsi_d/dt = u_d - R i_d + w_e psi_q,   dpsi_q/dt = u_q - R i_q - w_e psi_d,
 *   T_e = 3/2 p (psi_d i_q - psi_q i_d),
 * with i = i(psi) from the magnetic model. Mechanics:
 *   J dw_m/dt = T_e - T_L - B w_m - T_c sat(w_m / w_c),
 * or the speed imposed by a load machine (ideal, or a speed-controlled load
 * machine with a PI of finite bandwidth, as on the papers' test benches).
 * Energy meters (input, copper loss, air-gap power) are integrated alongside
 * the states so that the power balance can be checked exactly.
 */
#ifndef FS_PMSM_H
#define FS_PMSM_H

#include "fs_magnetic.h"

typedef enum {
    FS_LOAD_TORQUE = 0,       /* load torque profile on the free shaft */
    FS_LOAD_SPEED_IDEAL = 1,  /* speed imposed exactly by the load machine */
    FS_LOAD_SPEED_PI = 2      /* speed-controlled load machine, finite bandwidth */
} fs_load_kind;

typedef struct {
    int pole_pairs;
    double R_s;
    fs_mag_config mag;
    double J;                 /* motor inertia, kg m^2 */
    double B;                 /* viscous friction, N m s/rad */
    double T_coulomb;         /* Coulomb friction, N m */
    double w_coulomb;         /* speed of its linear region around zero, rad/s */
    int load_kind;            /* fs_load_kind */
    double J_load;            /* load machine inertia (SPEED_PI), kg m^2 */
    double load_bandwidth;    /* load machine speed loop, rad/s (SPEED_PI) */
} fs_pmsm_config;

/* State vector layout. */
enum {
    FS_X_PSI_D = 0, FS_X_PSI_Q, FS_X_W_M, FS_X_THETA_M, FS_X_LOAD_I,
    FS_X_E_IN, FS_X_E_CU, FS_X_E_AIRGAP, FS_X_UD_INT, FS_X_UQ_INT,
    FS_X_N
};

typedef struct {
    fs_pmsm_config cfg;
    fs_mag mag;
    double k_p_load, k_i_load;  /* load machine PI, designed in init */
} fs_pmsm;

/* Inputs of the right-hand side that are held over an integration step. */
typedef struct {
    double u_alpha, u_beta;   /* terminal voltage, stationary frame */
    double T_load;            /* external load torque, N m */
    double w_load;            /* load machine speed (reference), rad/s */
    double dw_load;           /* its slope, rad/s^2 */
} fs_pmsm_input;

int fs_pmsm_init(fs_pmsm *m, const fs_pmsm_config *cfg);
void fs_pmsm_deriv(fs_pmsm *m, const double *x, const fs_pmsm_input *in, double *dx);
/* Currents (rotor frame), torque and shaft load torque of a state. */
void fs_pmsm_outputs(fs_pmsm *m, const double *x, const fs_pmsm_input *in,
                     double *i_d, double *i_q, double *T_e, double *T_shaft);
/* Classic RK4 step of length h with held input. */
void fs_pmsm_rk4(fs_pmsm *m, double *x, const fs_pmsm_input *in, double h);

#endif /* FS_PMSM_H */
