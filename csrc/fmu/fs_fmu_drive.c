/* The drive as an FMU's model: fs_drive_init on the configuration
 * `fullspeed export` writes for the firmware (fs_config.c), with the
 * parameters the model description exposes set before it, and one
 * fs_drive_step a doStep. The inputs are what the firmware samples (the
 * phase currents, the dc link, the encoder), the references and the
 * sensorless switch; the outputs are fs_drive_out's duties and telemetry, for
 * the next update instant: a master that applies them after the step has the
 * firmware's one period of computation delay (fs_drive.h, config delay = 1). */
#include <stdio.h>
#include <stdlib.h>

#include "../control/fs_config.h"
#include "../control/fs_drive.h"
#include "fs_fmu.h"

struct fs_fmu {
    double v[FS_FMU_NV];
    fs_drive_config cfg;
    fs_drive drv;
};

static const int PHASE_IN[FS_PHASES_MAX] = {FS_VR_I_A, FS_VR_I_B, FS_VR_I_C, FS_VR_I_D, FS_VR_I_E};
static const int DUTY_OUT[FS_PHASES_MAX] = {FS_VR_DUTY_A, FS_VR_DUTY_B, FS_VR_DUTY_C, FS_VR_DUTY_D, FS_VR_DUTY_E};

fs_fmu *fs_fmu_new(void)
{
    fs_fmu *m = calloc(1, sizeof(*m));
    if (!m) return NULL;
    for (int k = 0; k < FS_FMU_NV; ++k) m->v[k] = fs_fmu_start_value[k];
    return m;
}

void fs_fmu_free(fs_fmu *m) { free(m); }

double *fs_fmu_values(fs_fmu *m) { return m->v; }

int fs_fmu_start(fs_fmu *m, char *msg, int len)
{
    const double *v = m->v;
    m->cfg = fs_config;
    /* the parameters fs_drive_init designs from (the rest stays as exported) */
    m->cfg.R_s = (float)v[FS_VR_R_S];
    m->cfg.L_d = (float)v[FS_VR_L_D];
    m->cfg.L_q = (float)v[FS_VR_L_Q];
    m->cfg.psi_f = (float)v[FS_VR_PSI_F];
    m->cfg.J = (float)v[FS_VR_J];
    m->cfg.B = (float)v[FS_VR_B];
    m->cfg.i_max = (float)v[FS_VR_I_MAX];
    m->cfg.T_max = (float)v[FS_VR_T_MAX];
    m->cfg.bw_current = (float)v[FS_VR_BW_CURRENT];
    m->cfg.bw_speed = (float)v[FS_VR_BW_SPEED];
    m->cfg.bw_pll = (float)v[FS_VR_BW_PLL];
    m->cfg.lock_time = (float)v[FS_VR_LOCK_TIME];
    fs_status st = fs_drive_init(&m->drv, &m->cfg);
    if (st != FS_OK) {
        snprintf(msg, (size_t)len, "fs_drive_init refused the configuration: %s: %s",
                 m->drv.fail ? m->drv.fail : "?", fs_status_str(st));
        return FS_FMU_FAIL;
    }
    return FS_FMU_OK;
}

/* fs_drive_fault, as the model description says (workflows/fmu.py) */
static const char *fault_name(int fault)
{
    switch (fault) {
    case FS_FAULT_POLARITY: return "polarity undetermined";
    case FS_FAULT_LOCK: return "lock lost and not re-acquired";
    case FS_FAULT_OVERSPEED: return "overspeed";
    case FS_FAULT_START: return "the I/f start never handed over";
    default: return "unknown";
    }
}

int fs_fmu_step(fs_fmu *m, char *msg, int len)
{
    double *v = m->v;
    fs_drive_in in = {0};
    fs_drive_out out;
    const int phases = m->cfg.phases;
    for (int k = 0; k < phases; ++k) in.i_ph[k] = (float)v[PHASE_IN[k]];
    in.u_dc = (float)v[FS_VR_U_DC];
    in.theta_m_enc = (float)v[FS_VR_THETA_M_ENC];
    in.theta_e_ext = (float)v[FS_VR_THETA_E_EXT];
    in.w_e_ext = (float)v[FS_VR_W_E_EXT];
    in.w_m_ref = (float)v[FS_VR_W_M_REF];
    in.i_d_ref = (float)v[FS_VR_I_D_REF];
    in.i_q_ref = (float)v[FS_VR_I_Q_REF];
    in.u_d_ref = (float)v[FS_VR_U_D_REF];
    in.u_q_ref = (float)v[FS_VR_U_Q_REF];
    in.w_e_ref = (float)v[FS_VR_W_E_REF];
    in.sensorless = v[FS_VR_SENSORLESS] != 0.0;
    const double fault_before = v[FS_VR_FAULT];
    fs_drive_step(&m->drv, &in, &out);
    for (int k = 0; k < phases; ++k) v[DUTY_OUT[k]] = out.duty[k];
    v[FS_VR_THETA_E] = out.theta_e;
    v[FS_VR_W_E] = out.w_e;
    v[FS_VR_THETA_EST] = out.theta_est;
    v[FS_VR_W_EST] = out.w_est;
    v[FS_VR_EST_VALID] = out.est_valid;
    v[FS_VR_I_D_HAT] = out.i_d;
    v[FS_VR_I_Q_HAT] = out.i_q;
    v[FS_VR_I_D_CMD] = out.i_d_ref;
    v[FS_VR_I_Q_CMD] = out.i_q_ref;
    v[FS_VR_T_REF] = out.T_ref;
    v[FS_VR_STAGE] = out.stage;
    v[FS_VR_FAULT] = out.fault;
    v[FS_VR_LOCK_LOST] = out.lock_lost;
    if (out.fault != FS_FAULT_NONE && fault_before == 0.0)
        snprintf(msg, (size_t)len, "the drive halted: fault %d (%s): the PWM must be turned off", out.fault,
                 fault_name(out.fault));
    return FS_FMU_OK;
}
