/* Two-node thermal model of a PMSM (double), for simulation.
 *
 * Nodes: the winding (with the stator teeth it sits in) at T_w, and the
 * magnets (with the rotor) at T_m, in degC:
 *   C_w dT_w/dt = P_cu + (1 - k_rotor) P_fe - (T_w - T_amb)/R_wa - (T_w - T_m)/R_wm
 *   C_m dT_m/dt =             k_rotor  P_fe - (T_m - T_amb)/R_ma + (T_w - T_m)/R_wm
 * The copper loss P_cu is the plant's own (its energy meter over each
 * control period, at the resistance of that period); the iron loss P_fe is
 * the machine's iron-loss model (fs_losses.h, the one the plant draws from
 * the shaft when its losses are on) at the stator flux, evaluated by the
 * caller with `iron`.
 *
 * The temperatures set the parameters:
 *   R_s = R_s,ref (1 + alpha_cu (T_w - T_ref)),
 *   magnet remanence (its equivalent current) x (1 + alpha_br (T_m - T_ref)).
 *
 * time_scale: the capacities are divided by it, so a machine whose real
 * time constants are minutes heats in seconds of simulation; the
 * temperatures it settles at depend on the resistances and losses alone and
 * are the real ones. Integrated by backward Euler over each control period
 * (unconditionally stable whatever the scale).
 */
#ifndef FS_THERMAL_H
#define FS_THERMAL_H

#include "../control/fs_types.h"
#include "fs_losses.h"

typedef struct {
    int enabled;              /* 0: no thermal model (the fields below are ignored) */
    double T_amb;             /* ambient (coolant, housing sink), degC */
    double T_ref;             /* temperature of the machine's R_s and psi_f, degC */
    double T_w0, T_m0;        /* initial winding and magnet temperatures, degC */
    double R_wa, R_wm, R_ma;  /* thermal resistances winding-ambient, winding-magnet, magnet-ambient, K/W */
    double C_w, C_m;          /* heat capacities, J/K */
    double alpha_cu;          /* copper resistance coefficient, 1/K */
    double alpha_br;          /* magnet remanence coefficient, 1/K (< 0 for NdFeB) */
    fs_iron_config iron;      /* the machine's iron loss (psi_ref: the magnet's flux) */
    double k_rotor;           /* share of the iron loss in the rotor (heats the magnets), 0..1 */
    double time_scale;        /* >= 1: capacities divided by it */
} fs_thermal_config;

typedef struct {
    fs_thermal_config cfg;
    double T_w, T_m;          /* degC */
    double P_cu, P_fe;        /* the losses of the last step, W */
} fs_thermal;

/* FS_OK, FS_ERR_NULL for a NULL argument, or FS_ERR_PARAM for a field out
 * of range or not finite (resistances and capacities > 0, time_scale >= 1,
 * k_rotor in [0, 1], an iron loss fs_iron_check refuses,
 * |alpha| < 0.1 / K, temperatures in
 * [-273.15, 1000] degC, and each parameter factor positive from -50 degC to
 * 300 degC). */
fs_status fs_thermal_init(fs_thermal *th, const fs_thermal_config *cfg);
/* One backward-Euler step of length dt with losses P_cu and P_fe, W. */
void fs_thermal_step(fs_thermal *th, double P_cu, double P_fe, double dt);
/* R_s / R_s,ref and remanence / remanence at T_ref at the present temperatures. */
double fs_thermal_r_factor(const fs_thermal *th);
double fs_thermal_magnet_factor(const fs_thermal *th);

#endif /* FS_THERMAL_H */
