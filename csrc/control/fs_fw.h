/* Flux weakening by voltage-error feedback (zou2021, sec. 4.2, PART_1).
 *
 * The input is the q-axis voltage the current controller asked for minus the
 * q-axis voltage the modulator realised after (minimum-phase-error) over-
 * modulation, eq. (26). Gradient descent on F = (dv_d^2 + dv_q^2)/2 gives
 * d i_d/dt = -beta w_e L dv_q, eq. (28); a first-order low-pass at the
 * current-loop bandwidth replaces the integrator, eq. (30), so that i_d comes
 * back to its MTPA value by itself once the voltage is inside the limit.
 * beta = 1 / (w_e,max L)^2, eq. (31), makes the loop gain one at the top
 * speed; `gain` multiplies it (1: the paper). The loop's dc gain sets how much
 * voltage error is left at the limit: with gain g a fraction 1/(1+g) of the
 * excess the current controller asks for. Output: the d-current added to the
 * MTPA reference, <= 0.
 */
#ifndef FS_FW_H
#define FS_FW_H

#include "fs_types.h"

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

fs_status fs_fw_init(fs_fw *fw, const fs_fw_config *cfg);
void fs_fw_reset(fs_fw *fw);
/* dv_q = v_q* - v_q (eq. 26) at electrical speed w_e; returns the d-current
 * to add to the MTPA reference (<= 0). */
float fs_fw_step(fs_fw *fw, float dv_q, float w_e);

#endif /* FS_FW_H */
