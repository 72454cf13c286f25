/* Three- or five-phase PMSM with its mechanics and load (double), for
 * simulation.
 *
 * Electrical states are the stator flux linkages in rotor coordinates:
 *   dpsi_d/dt = u_d - R i_d + w_e psi_q,   dpsi_q/dt = u_q - R i_q - w_e psi_d,
 *   T_e = m/2 p (psi_d i_q - psi_q i_d),   m = phases,
 * with i = i(psi) from the magnetic model; (d, q) is the rotor frame of the
 * fundamental (alpha, beta) plane. A five-phase machine (amplitude-invariant
 * VSD, fs_inverter.h) also has the third-harmonic plane (x, y), in the frame
 * d3-q3 turning at 3 w_e (Park of (x, y) by 3 theta_e), linear (Yu, Wang,
 * Li, Energies 2022, eq. (1)):
 *   psi_d3 = L_d3 i_d3 + psi_f3,   psi_q3 = L_q3 i_q3,
 *   dpsi_d3/dt = u_d3 - R i_d3 + 3 w_e psi_q3,
 *   dpsi_q3/dt = u_q3 - R i_q3 - 3 w_e psi_d3,
 *   T_e = 5/2 p [psi_d i_q - psi_q i_d + 3 (psi_d3 i_q3 - psi_q3 i_d3)].
 * A three-phase machine neither has nor integrates the two extra states.
 * Mechanics:
 *   J dw_m/dt = T_e - T_L - B w_m - T_c sat(w_m / w_c),
 * or the speed imposed by a load machine (ideal, or a speed-controlled load
 * machine with a PI of finite bandwidth, as on the papers' test benches).
 * Energy meters (input, copper loss, air-gap power) are integrated alongside
 * the states so that the power balance can be checked exactly. With
 * `losses`, the iron loss (fs_losses.h) is drawn from the shaft as a drag
 * torque T_fe(w_m, |psi|):
 *   J dw_m/dt = T_e - T_L - B w_m - T_c sat(w_m / w_c) - T_fe,
 * and the meters of the shaft's side run too: E_FE = int T_fe w_m (iron),
 * E_MECH = int (B w_m + T_c sat(w_m / w_c)) w_m (friction) and E_SHAFT =
 * int T_L w_m (the load's work; an ideal speed load's torque is what the
 * shaft gives beyond J dw_m/dt), so that E_AIRGAP = E_FE + E_MECH + E_SHAFT
 * + the kinetic energy's change; and the stationary currents' integrals
 * (I_A_INT, I_B_INT, and I_X_INT, I_Y_INT for five phases), from which a
 * converter meters what it passes with coefficients held over a step.
 *
 * Spatial harmonics (three phases): the flux depends on the rotor angle
 * theta = theta_e as well. The magnet's harmonic flux h(theta) of orders
 * 5, 7, 11, 13 (psi_h[], Wb: in the stationary frame psi_5 e^{-j5 theta} +
 * psi_7 e^{j7 theta} + ..., phase a's back-EMF harmonic of order n is n
 * psi_n / psi_f of the fundamental), saliency harmonics as a flux transform
 * M(theta) = I + A(theta) of orders 6 and 12 in the rotor frame,
 *   A = sum_k [[sal_k[0] cos k theta, sal_k[2] sin k theta],
 *              [sal_k[2] sin k theta, sal_k[1] cos k theta]],  k = 6, 12,
 * and a cogging torque T_cog sin(cog_order theta). The currents come from
 * the magnetic model f (fs_magnetic.h) at the transformed flux
 *   phi = p0 + M (psi - h - p0),   i = M^T f(phi),
 * p0 its zero-current flux, so that with W0 the model's energy the stored
 * energy W(psi, theta) = W0(phi) + W_cog(theta) has i = grad_psi W (a
 * Gamma = M^T Gamma_0 M modulated with the angle: inductance harmonics that
 * act with the current), and the torque from the co-energy's angle
 * derivative keeps the balance exact:
 *   T_e = 3/2 p [psi_d i_q - psi_q i_d - dW/dtheta |psi],
 *   dW/dtheta |psi = f^T (A' (psi - h - p0) - M h') - T_cog sin(n theta) / (3/2 p).
 */
#ifndef FS_PMSM_H
#define FS_PMSM_H

#include "fs_losses.h"
#include "fs_magnetic.h"

typedef enum {
    FS_LOAD_TORQUE = 0,       /* load torque profile on the free shaft */
    FS_LOAD_SPEED_IDEAL = 1,  /* speed imposed exactly by the load machine */
    FS_LOAD_SPEED_PI = 2,     /* speed-controlled load machine, finite bandwidth */
    FS_LOAD_BRAKE = 3         /* a brake (powder, eddy current): the torque profile is its magnitude,
                                 opposing the motion; Karnopp stiction below w_coulomb */
} fs_load_kind;

typedef struct {
    int pole_pairs;
    double R_s;
    fs_mag_config mag;
    double J;                 /* motor inertia, kg m^2 */
    double B;                 /* viscous friction, N m s/rad */
    double T_coulomb;         /* Coulomb friction, N m */
    double w_coulomb;         /* speed of its linear region around zero, rad/s; BRAKE: its stick band */
    int load_kind;            /* fs_load_kind */
    double J_load;            /* load machine inertia (SPEED_PI), kg m^2 */
    double load_bandwidth;    /* load machine speed loop, rad/s (SPEED_PI) */
    int phases;               /* 3 or 5 */
    double L_d3, L_q3;        /* five phases: third-harmonic inductances, H (> 0) */
    double psi_f3;            /* five phases: third-harmonic magnet flux, Wb (>= 0) */
    /* spatial harmonics (three phases; all 0: none, and no cost) */
    double psi_h[4];          /* magnet flux harmonics of orders 5, 7, 11, 13, Wb (signed) */
    double sal6[3], sal12[3]; /* the flux transform's (dd, qq, dq) terms of orders 6 and 12; |sal6| + |sal12| < 0.5 each */
    double T_cog;             /* cogging torque amplitude, N m */
    int cog_order;            /* its order per electrical turn: 6, 12, 18 or 24 (needed with T_cog != 0) */
    /* losses beyond the copper (0: none, and no cost) */
    fs_iron_config iron;      /* with `losses`: the iron loss drawn from the shaft (P_ref 0: none) */
    int losses;               /* 1: the loss meters integrated (and the iron loss drawn) */
} fs_pmsm_config;

/* State vector layout: the first FS_X_N3 states are those of a
 * three-phase machine; a five-phase one adds the d3-q3 fluxes (FS_X_N5);
 * the loss meters follow, integrated with `losses` only. The energy
 * meters E_IN = m/2 int (u_alpha i_alpha + u_beta i_beta + u_x i_x + u_y i_y),
 * E_CU = m/2 R int (i_d^2 + i_q^2 + i_d3^2 + i_q3^2) and E_AIRGAP = int T_e w_m
 * balance with the stored magnetic energy (fs_pmsm_energy). UD_INT and
 * UQ_INT integrate the fundamental-plane voltage. */
enum {
    FS_X_PSI_D = 0, FS_X_PSI_Q, FS_X_W_M, FS_X_THETA_M, FS_X_LOAD_I,
    FS_X_E_IN, FS_X_E_CU, FS_X_E_AIRGAP, FS_X_UD_INT, FS_X_UQ_INT,
    FS_X_PSI_D3, FS_X_PSI_Q3,
    FS_X_E_FE, FS_X_E_MECH, FS_X_E_SHAFT,
    FS_X_I_A_INT, FS_X_I_B_INT, FS_X_I_X_INT, FS_X_I_Y_INT,
    FS_X_N
};
enum { FS_X_N3 = FS_X_PSI_D3, FS_X_N5 = FS_X_E_FE };

typedef struct {
    fs_pmsm_config cfg;
    fs_mag mag;
    double k_p_load, k_i_load;  /* load machine PI, designed in init */
    double inv_L_d3, inv_L_q3;  /* five phases: 1/L_d3, 1/L_q3 */
    double R_s0, psi_f30;       /* R_s and psi_f3 as configured (fs_pmsm_set_temperature scales them) */
    int harm;                   /* spatial harmonics configured */
    double p0_d, p0_q;          /* with them: the magnetic model's zero-current flux */
} fs_pmsm;

/* Inputs of the right-hand side that are held over an integration step. */
typedef struct {
    double u_alpha, u_beta;   /* terminal voltage, stationary frame, fundamental plane */
    double u_x, u_y;          /* five phases: third-harmonic plane (ignored for three) */
    double T_load;            /* external load torque, N m */
    double w_load;            /* load machine speed (reference), rad/s */
    double dw_load;           /* its slope, rad/s^2 */
    /* an open phase (three phases): 0 none, 1..3 phase a..c. Its current is
     * held at zero by the terminal voltage along that phase's axis, which
     * floats; a current flowing when it opens decays with tau_open, s. */
    int open_phase;
    double tau_open;
} fs_pmsm_input;

/* FS_OK (0), or the status of the first field out of range or not finite
 * (FS_ERR_PARAM for an iron loss fs_iron_check refuses):
 * FS_ERR_POLE_PAIRS, FS_ERR_RS, FS_ERR_J (J > 0), FS_ERR_PARAM (B,
 * T_coulomb, J_load >= 0; w_coulomb > 0 with Coulomb friction or a brake;
 * load_bandwidth > 0 for SPEED_PI, finite always; phases 3 or 5),
 * FS_ERR_MODE (load_kind), the magnetic model's (fs_mag_init), and for five
 * phases FS_ERR_LD, FS_ERR_LQ, FS_ERR_PSI_F (L_d3, L_q3 > 0, psi_f3 >= 0);
 * FS_ERR_PARAM for spatial harmonics not finite, a transform term out of
 * range, a cogging order not 6, 12, 18 or 24, or harmonics on five phases. */
fs_status fs_pmsm_init(fs_pmsm *m, const fs_pmsm_config *cfg);
/* The state at rest without current: fluxes at zero current (psi_d3 =
 * psi_f3 for five phases), everything else zero. */
void fs_pmsm_initial_state(fs_pmsm *m, double *x);
/* With spatial harmonics: the fluxes of zero current at the state's angle
 * (after the angle is set); without, nothing. */
void fs_pmsm_rest_flux(fs_pmsm *m, double *x);
/* Rotor-frame currents of a state whose electrical angle has cosine cs and
 * sine sn (read only with spatial harmonics). */
void fs_pmsm_current_dq(fs_pmsm *m, const double *x, double cs, double sn, double *i_d, double *i_q);
void fs_pmsm_deriv(fs_pmsm *m, const double *x, const fs_pmsm_input *in, double *dx);
/* Currents (rotor frame), torque and shaft load torque of a state. */
void fs_pmsm_outputs(fs_pmsm *m, const double *x, const fs_pmsm_input *in,
                     double *i_d, double *i_q, double *T_e, double *T_shaft);
/* The iron loss (W) and its drag torque (N m) at a state. */
void fs_pmsm_iron(const fs_pmsm *m, const double *x, double *P_fe, double *T_fe);
/* Third-harmonic currents (d3-q3 frame) of a state; 0 for three phases. */
void fs_pmsm_currents3(const fs_pmsm *m, const double *x, double *i_d3, double *i_q3);
/* Stored magnetic energy m/2 (W(psi) + W3), W3 = (psi_d3 - psi_f3)^2/(2 L_d3)
 * + psi_q3^2/(2 L_q3) (W as fs_mag_energy; 0 for three phases), J. */
double fs_pmsm_energy(const fs_pmsm *m, const double *x);
/* The winding's resistance at r times the configured R_s and the magnet's
 * remanence at k times the configured one (fs_mag_set_magnet; psi_f3 with
 * it), from a thermal model. The currents are kept: the flux states move
 * with the magnet (the EMF of that slow change, d psi_f/dt, is neglected,
 * and so is the energy it exchanges, which the meters do not see). */
void fs_pmsm_set_temperature(fs_pmsm *m, double *x, double r, double k);
/* Classic RK4 step of length h with held input. */
void fs_pmsm_rk4(fs_pmsm *m, double *x, const fs_pmsm_input *in, double h);

/* A state's electrical angle's cosine and sine and its rotor-frame
 * currents (fs_pmsm_current_dq), as a caller computed them before a step
 * from that state (the switching inverter's segment needs the currents for
 * its voltage): the step's first stage takes them instead of computing
 * them again. `reuse` says the currents are the ones the first stage would
 * compute, to the bit: not with spatial harmonics (the stage needs the
 * energy's angle term too) nor with a flux map (its solve starts from the
 * last solution, fs_mag_current's hint, so a second solve of the same
 * state can differ in the last bit); the angle's cosine and sine always. */
typedef struct {
    double cs, sn;
    double i_d, i_q;
    int reuse;
} fs_pmsm_at;
void fs_pmsm_at_state(fs_pmsm *m, const double *x, fs_pmsm_at *a);
/* fs_pmsm_rk4 from state x, whose fs_pmsm_at is a: the same result to the bit. */
void fs_pmsm_rk4_at(fs_pmsm *m, double *x, const fs_pmsm_input *in, double h, const fs_pmsm_at *a);
/* fs_pmsm_outputs of state x, whose fs_pmsm_at is a (or NULL): the currents
 * taken from a where a->reuse says they are the same bits. */
void fs_pmsm_outputs_at(fs_pmsm *m, const double *x, const fs_pmsm_input *in, const fs_pmsm_at *a,
                        double *i_d, double *i_q, double *T_e, double *T_shaft);

#endif /* FS_PMSM_H */
