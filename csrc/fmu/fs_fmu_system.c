/* The closed loop as an FMU's model: fullspeed's runner (csrc/sim: the
 * plant, the converter, the sensors and the drive) on the fs_sim_config
 * fullspeed builds for the scenario (fullspeed.sim.build_config),
 * serialized as C (fs_system.c). The master's inputs take the place of the
 * scenario's reference and load profiles (fs_sim_hold); the rest of the
 * scenario (the sensorless switch, a dc-link fault) runs as it is.
 *
 * A doStep from t to t + Ts runs the sample at t (the drive's response to
 * the inputs as set) and the plant over the period. Afterwards the outputs
 * are: the plant at t + Ts (speed, angle, torque, currents: the channels the
 * next sample records), the dc link over the period (fs_sim_dc_link), and
 * the drive's outputs of the sample at t (duties, stage, the angle error
 * then), held over the period as a sampled controller's are. */
#include <stdio.h>
#include <stdlib.h>

#include "../sim/fs_sim.h"
#include "../sim/fs_system.h"
#include "fs_fmu.h"

struct fs_fmu {
    double v[FS_FMU_NV];
    fs_sim *sim;
    double row[FS_CH_N];
};

fs_fmu *fs_fmu_new(void)
{
    fs_fmu *m = calloc(1, sizeof(*m));
    if (!m) return NULL;
    for (int k = 0; k < FS_FMU_NV; ++k) m->v[k] = fs_fmu_start_value[k];
    return m;
}

void fs_fmu_free(fs_fmu *m)
{
    if (!m) return;
    fs_sim_destroy(m->sim);
    free(m);
}

double *fs_fmu_values(fs_fmu *m) { return m->v; }

/* The outputs that show a trace channel, from the row. */
static void channels_out(fs_fmu *m)
{
    for (int k = 0; k < FS_FMU_NV; ++k) {
        if (fs_fmu_type[k] && fs_fmu_channel[k] >= 0) m->v[k] = m->row[fs_fmu_channel[k]];
    }
}

int fs_fmu_start(fs_fmu *m, char *msg, int len)
{
    fs_sim_config c = fs_system;
    c.decimation = 1;   /* a row each sample: the step's */
    fs_sim_destroy(m->sim);
    m->sim = fs_sim_create(&c, msg, len);
    if (!m->sim) return FS_FMU_FAIL;
    fs_sim_plant_row(m->sim, m->row);
    channels_out(m);
    return FS_FMU_OK;
}

/* The master's inputs in place of the profiles they stand for. */
static void hold_inputs(fs_fmu *m)
{
    static const int held[][2] = {
        {FS_VR_W_M_REF, FS_SIM_W_M_REF}, {FS_VR_I_D_REF, FS_SIM_I_D_REF}, {FS_VR_I_Q_REF, FS_SIM_I_Q_REF},
        {FS_VR_U_D_REF, FS_SIM_U_D_REF}, {FS_VR_U_Q_REF, FS_SIM_U_Q_REF}, {FS_VR_W_E_REF, FS_SIM_W_E_REF},
        {FS_VR_T_LOAD, FS_SIM_T_LOAD},
    };
    for (size_t k = 0; k < sizeof(held) / sizeof(held[0]); ++k) {
        if (fs_fmu_type[held[k][0]]) fs_sim_hold(m->sim, held[k][1], m->v[held[k][0]], 0.0);
    }
    if (fs_fmu_type[FS_VR_W_LOAD]) fs_sim_hold(m->sim, FS_SIM_W_LOAD, m->v[FS_VR_W_LOAD], m->v[FS_VR_DW_LOAD]);
}

static const char *stop_name(int rc)
{
    switch (rc) {
    case FS_STOP_NAN: return "a state became NaN or infinite";
    case FS_STOP_OVERCURRENT: return "overcurrent: a phase current beyond the trip level";
    case FS_STOP_LOSS_OF_LOCK: return "loss of lock: the drive's monitor flagged it";
    case FS_STOP_POLARITY: return "polarity undetermined: the drive refused to start";
    case FS_STOP_OVERSPEED: return "overspeed: the drive halted at its overspeed limit";
    case FS_STOP_START: return "start failed: the I/f start never handed over to the observer";
    default: return "stopped";
    }
}

int fs_fmu_step(fs_fmu *m, char *msg, int len)
{
    hold_inputs(m);
    int rows = 0;   /* one doStep is one control period */
    const int rc = fs_sim_run_steps(m->sim, fs_sim_step_count(m->sim) + 1, m->row, 1, &rows);
    if (rc == FS_RUN_DONE) {
        fs_sim_plant_row(m->sim, m->row);
        fs_sim_dc_link(m->sim, &m->v[FS_VR_U_DC], &m->v[FS_VR_I_DC], &m->v[FS_VR_P_DC]);
        channels_out(m);
        return FS_FMU_OK;
    }
    if (rows == 1) channels_out(m);   /* the sample that stopped it */
    m->v[FS_VR_STOP] = rc;
    snprintf(msg, (size_t)len, "the closed loop stopped at t = %.9g s: %s", fs_sim_stop_time(m->sim), stop_name(rc));
    return rc == FS_RUN_BUFFER_FULL || rc < 0 ? FS_FMU_FAIL : FS_FMU_STOPPED;
}
