/* Flux weakening by voltage-error feedback (zou2021, sec. 4.2, PART_1).
 *
 * The input is the q-axis voltage the current regulator asks for minus the
 * q-axis voltage the modulator realised after (minimum-phase-error) over-
 * modulation, eq. (26). Gradient descent on F = (dv_d^2 + dv_q^2)/2 gives
 * d i_d/dt = -beta w_e L dv_q, eq. (28); a first-order low-pass replaces
 * the integrator, eq. (30), so that i_d comes back to its MTPA value by
 * itself once the voltage is inside the limit. beta = 1 / (w_e,max L)^2,
 * eq. (31); `gain` multiplies it (1: the paper). Output: the d-current
 * added to the MTPA reference (i_d* of eq. (30); i_q* is left as the speed
 * loop asks), <= 0. Its dc gain, eq. (30)'s, is k = gain w_e / (w_e,max^2 L).
 *
 * What holds dv_q in steady state. The low-pass is type 0: its output needs
 * a standing dv_q = |i_d| / k. Where the regulators' anti-windup winds
 * their integrals back to the realised voltage every sample, the only dv_q
 * left is their one-sample increment Ts k_i e, so the low-pass holds i_d
 * only on a standing current error e_q = |i_d| / (k Ts k_i) (2 to 5 A on
 * zou2021's machine at 1500-1750 rpm; the speed loop's integral carries it
 * in i_q*). The paper's eq. (26) says otherwise: in flux weakening its
 * v_q* = w_e (L i_d0* + psi_f), the voltage for the MTPA current, which a
 * regulator gives only if it keeps the over-modulation excess in its
 * integral (at gain 1 and w_e,max, |i_d| = dv_q / (w_e L) exactly). That
 * is fs_fw_hold's reading: the regulators keep the excess (wind back only
 * what PART_1 cannot use), the integral closes the loop and e -> 0. With
 * the paper's regulators (internal model, k_p = alpha L, k_i = alpha R_s:
 * sec. 4.2, fs_current_ctrl.h) the loop from e_q through the integral, the
 * low-pass and the machine (at the voltage limit, i_q/i_d = -w_e/(s +
 * R_s/L)) is K w_c / (s (s + w_c)), K = gain alpha (w_e/w_e,max)^2: the
 * paper's w_c = alpha at gain 1 is its zeta = 0.5 design, but it crosses
 * over at the current loop's bandwidth, where the sampled loop's delay
 * makes it oscillate; see fs_drive.h for the gain and cutoff designed
 * instead. A regulator whose zero is not on R_s/L (the pole placement)
 * leaves three poles below its zero: the held loop limit-cycles.
 */
#ifndef FS_FW_H
#define FS_FW_H

#include "fs_types.h"
#include "fs_transforms.h"

typedef struct {
    float Ts;          /* s */
    float L;           /* H: L_s of an SPMSM, L_d of an IPMSM */
    float w_e_max;     /* top electrical speed for eq. (31), rad/s */
    float gain;        /* multiplies beta of eq. (31); 1: the paper */
    float bandwidth;   /* low-pass cutoff w_c, rad/s (the current-loop bandwidth) */
    float i_max;       /* the d-current added is limited to -i_max, A */
} fs_fw_config;

typedef struct {
    fs_fw_config cfg;
    float beta;        /* eq. (31), A / (V rad/s H) */
    float a;           /* exp(-w_c Ts) */
    float i_d;         /* the filter's output, A */
} fs_fw;

/* The gain and cutoff left 0 in cfg, designed from the current loop's
 * bandwidth and the top speed as fs_drive.h says, for the excess held by the
 * regulators or wound back (fs_fw_init then checks them); a NULL cfg: nothing. */
void fs_fw_design(fs_fw_config *cfg, float bw_current, bool hold);
fs_status fs_fw_init(fs_fw *fw, const fs_fw_config *cfg);
void fs_fw_reset(fs_fw *fw);
/* dv_q = v_q* - v_q (eq. 26) at electrical speed w_e; returns the d-current
 * to add to the MTPA reference (<= 0). */
float fs_fw_step(fs_fw *fw, float dv_q, float w_e);

/* The voltage the current regulators' integrals wind back to (held
 * reading above): the realised u_real plus the excess u_ref - u_real, all
 * of it while the excess deepens i_d (w_e dv_q > 0) and PART_1's output is
 * above -i_max; at -i_max only the share that keeps it there (more would
 * wind up), none when the excess is of the sign that cannot weaken. */
fs_dq fs_fw_hold(const fs_fw *fw, fs_dq u_ref, fs_dq u_real, float w_e);

#endif /* FS_FW_H */
