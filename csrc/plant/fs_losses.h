/* Where the power goes beyond the copper (double), for simulation: the
 * machine's iron loss and the converter's power semiconductors.
 *
 * Iron loss (one model for the plant's drag and the thermal model's heat):
 * a Steinmetz-type split into hysteresis (proportional to the frequency)
 * and eddy currents (to its square), with the stator flux magnitude |psi|
 * over a reference flux:
 *   P_fe = P_ref [k_hyst f r^beta + (1 - k_hyst) f^2 r^2],
 *   f = |w_e| / w_ref,  r = |psi| / psi_ref,
 * P_ref the loss at w_ref with |psi| = psi_ref, k_hyst the hysteresis share
 * there, beta the hysteresis part's flux exponent (the eddy part's is 2).
 * The plant draws it from the shaft as a drag torque T_fe = P_fe / w_m:
 * the hysteresis part a Coulomb-like torque (smoothed linearly within
 * +-w_band), the eddy part a viscous one; above w_band, T_fe w_m = P_fe.
 * At the machine level the flux linkage stands for the flux density
 * (B ~ psi / (N A)), so the coefficients are the machine's, not the
 * steel's: a machine file says how they were formed.
 *
 * Devices (a leg of the two-level inverter, the matrix converter's stages):
 * a transistor (IGBT or MOSFET channel) and its freewheeling diode, each a
 * threshold voltage and a slope resistance,
 *   v = sign(i) u_0 + r i,
 * and the energies of a commutation at current |i| and voltage v, scaled
 * from the datasheet's values at (I_ref, V_ref) by the usual power laws
 * (as in Semikron's Application Manual Power Semiconductors, 2015, on losses):
 *   E_on, E_off = E_ref (|i| / I_ref)^k_i_t (v / V_ref)^k_v_t   (transistor),
 *   E_rr        = E_ref (|i| / I_ref)^k_i_d (v / V_ref)^k_v_d   (diode).
 * In a commutation the conducting transistor turns off (E_off), or the
 * incoming transistor turns on hard against the conducting diode (E_on +
 * E_rr of that diode): which one is the current's sign against the state
 * the leg leaves. A MOSFET's channel carries the current both ways; its
 * body diode conducts only in the dead time.
 */
#ifndef FS_LOSSES_H
#define FS_LOSSES_H

#include "../control/fs_types.h"

typedef struct {
    double P_ref;             /* W at w_ref with |psi| = psi_ref (0: no iron loss) */
    double w_ref;             /* rad/s, electrical */
    double psi_ref;           /* Wb */
    double k_hyst;            /* hysteresis share of P_ref, 0..1 */
    double beta;              /* the hysteresis part's flux exponent (2: P_ref r^2 [k f + (1 - k) f^2]) */
    double w_band;            /* rad/s, mechanical: the hysteresis drag's linear band around standstill */
} fs_iron_config;

/* FS_OK, or FS_ERR_PARAM: P_ref >= 0, w_ref, psi_ref > 0, k_hyst in [0, 1],
 * beta in [1, 3], w_band > 0, all finite (P_ref = 0 needs none of the rest). */
fs_status fs_iron_check(const fs_iron_config *c);
/* The iron loss at electrical speed w_e with stator flux magnitude psi, W. */
double fs_iron_loss(const fs_iron_config *c, double w_e, double psi);
/* The drag torque that draws it from the shaft at mechanical speed w_m
 * with pole_pairs p (signed with w_m), N m. */
double fs_iron_torque(const fs_iron_config *c, int pole_pairs, double w_m, double psi);

typedef enum { FS_DEV_IGBT = 0, FS_DEV_MOSFET = 1 } fs_device_kind;

typedef struct {
    int enabled;              /* 0: ideal switches (fs_inverter's u_on, r_on act instead) */
    int kind;                 /* fs_device_kind */
    double u_t, r_t;          /* transistor: threshold V, slope resistance ohm */
    double u_d, r_d;          /* diode */
    double E_on, E_off, E_rr; /* J per commutation at I_ref, V_ref */
    double I_ref, V_ref;      /* A, V */
    double k_i_t, k_v_t;      /* the transistor energies' current and voltage exponents */
    double k_i_d, k_v_d;      /* the diode's recovery energy's */
} fs_device_config;

/* FS_OK, or FS_ERR_PARAM: kind known; drops, resistances and energies >= 0;
 * I_ref, V_ref > 0; exponents in [0, 3]; all finite (disabled: FS_OK). */
fs_status fs_device_check(const fs_device_config *c);
/* The forward drop of the transistor (transistor != 0) or the diode at
 * current i along its conduction (signed as i), V. */
double fs_device_drop(const fs_device_config *c, int transistor, double i);
/* The energy of one commutation of a leg leaving state `high_before` (1:
 * the upper device conducted, 0: the lower) at current i (positive out of
 * the leg) and link voltage v, J. */
double fs_device_commutation(const fs_device_config *c, int high_before, double i, double v);
/* Whether the transistor (1) or the diode (0) of the device on rail
 * `high` (1: upper) carries a current i out of the leg; a MOSFET's channel
 * always (outside the dead time). */
int fs_device_transistor(const fs_device_config *c, int high, double i);

#endif /* FS_LOSSES_H */
