#include "fs_fmi_inst.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

fs_inst *fs_inst_new(const char *name, fs_inst_log *log, void *front, int logging)
{
    fs_inst *inst = calloc(1, sizeof(*inst));
    if (!inst) return NULL;
    inst->m = fs_fmu_new();
    if (!inst->m) {
        free(inst);
        return NULL;
    }
    snprintf(inst->name, sizeof(inst->name), "%s", name ? name : "");
    inst->log = log;
    inst->front = front;
    inst->logging = logging;
    inst->state = FS_INST_INSTANTIATED;
    return inst;
}

void fs_inst_free(fs_inst *inst)
{
    if (!inst) return;
    fs_fmu_free(inst->m);
    free(inst);
}

static int fail(fs_inst *inst, const char *category, int status)
{
    if (inst->log) inst->log(inst, status, category, inst->msg);
    return status;
}

int fs_inst_unsupported(fs_inst *inst, const char *function)
{
    snprintf(inst->msg, sizeof(inst->msg), "%s: not supported by this FMU (co-simulation, fixed step)", function);
    return fail(inst, "logStatusError", FS_ST_ERROR);
}

int fs_inst_check(fs_inst *inst, unsigned vr, int type, int set)
{
    static const char *types[] = {"", "a real", "an integer", "a Boolean"};
    if (vr >= FS_FMU_NV || fs_fmu_type[vr] == 0) {
        snprintf(inst->msg, sizeof(inst->msg), "value reference %u: no such variable in this FMU", vr);
        return fail(inst, "logStatusError", FS_ST_ERROR);
    }
    if (fs_fmu_type[vr] != type) {
        snprintf(inst->msg, sizeof(inst->msg), "value reference %u (%s) is %s, not %s", vr, fs_fmu_name[vr],
                 types[fs_fmu_type[vr]], types[type]);
        return fail(inst, "logStatusError", FS_ST_ERROR);
    }
    if (!set) return FS_ST_OK;
    const int c = fs_fmu_causality[vr];
    const int before = inst->state == FS_INST_INSTANTIATED || inst->state == FS_INST_INITIALIZATION;
    if (c == FS_FMU_INPUT && (before || inst->state == FS_INST_STEP)) return FS_ST_OK;
    if (c == FS_FMU_PARAMETER && before) return FS_ST_OK;
    snprintf(inst->msg, sizeof(inst->msg), "%s may not be set %s", fs_fmu_name[vr],
             c == FS_FMU_PARAMETER ? "after initialization: fs_drive_init takes it (a fixed parameter)"
             : c == FS_FMU_INPUT ? "once the instance is stopped, terminated or failed" : "(not an input or parameter)");
    return fail(inst, "logStatusError", FS_ST_ERROR);
}

double fs_inst_value(fs_inst *inst, unsigned vr)
{
    return vr == FS_VR_TIME ? inst->t : fs_fmu_values(inst->m)[vr];
}

void fs_inst_set(fs_inst *inst, unsigned vr, double value) { fs_fmu_values(inst->m)[vr] = value; }

int fs_inst_enter_init(fs_inst *inst, double t_start)
{
    if (inst->state != FS_INST_INSTANTIATED) {
        snprintf(inst->msg, sizeof(inst->msg), "enter initialization mode: only once after instantiation or reset");
        return fail(inst, "logStatusError", FS_ST_ERROR);
    }
    if (t_start != 0.0) {
        snprintf(inst->msg, sizeof(inst->msg), "start time %.9g s: the drive and the scenario start at t = 0", t_start);
        return fail(inst, "logStatusError", FS_ST_ERROR);
    }
    inst->t = 0.0;
    inst->state = FS_INST_INITIALIZATION;
    return FS_ST_OK;
}

int fs_inst_exit_init(fs_inst *inst)
{
    if (inst->state != FS_INST_INITIALIZATION) {
        snprintf(inst->msg, sizeof(inst->msg), "exit initialization mode: not in initialization mode");
        return fail(inst, "logStatusError", FS_ST_ERROR);
    }
    inst->msg[0] = '\0';
    if (fs_fmu_start(inst->m, inst->msg, (int)sizeof(inst->msg)) != FS_FMU_OK) {
        inst->state = FS_INST_ERROR;
        return fail(inst, "logStatusError", FS_ST_ERROR);
    }
    inst->state = FS_INST_STEP;
    return FS_ST_OK;
}

int fs_inst_do_step(fs_inst *inst, double t, double h)
{
    if (inst->state != FS_INST_STEP) {
        snprintf(inst->msg, sizeof(inst->msg), "doStep at t = %.9g s: %s", t,
                 inst->state == FS_INST_STOPPED ? "the closed loop has stopped" : "not initialized, or failed");
        return fail(inst, "logStatusError", FS_ST_ERROR);
    }
    /* one control period (a master's n Ts - (n - 1) Ts differs from Ts by rounding) */
    if (!(fabs(h - FS_FMU_TS) <= 1e-6 * FS_FMU_TS) || !(fabs(t - inst->t) <= 1e-6 * FS_FMU_TS)) {
        snprintf(inst->msg, sizeof(inst->msg),
                 "doStep from t = %.9g s by %.9g s: the step must be one control period, %.9g s, from the last "
                 "communication point %.9g s", t, h, FS_FMU_TS, inst->t);
        return fail(inst, "logStatusError", FS_ST_ERROR);
    }
    inst->msg[0] = '\0';
    const int rc = fs_fmu_step(inst->m, inst->msg, (int)sizeof(inst->msg));
    if (rc == FS_FMU_FAIL) {
        inst->state = FS_INST_ERROR;
        return fail(inst, "logStatusError", FS_ST_ERROR);
    }
    if (rc == FS_FMU_STOPPED) {
        inst->state = FS_INST_STOPPED;
        inst->t_stop = inst->t;
        fail(inst, "logEvents", FS_ST_WARNING);
        return FS_ST_DISCARD;
    }
    if (inst->msg[0]) fail(inst, "logEvents", FS_ST_WARNING);
    inst->t = t + h;
    return FS_ST_OK;
}

int fs_inst_terminate(fs_inst *inst)
{
    inst->state = FS_INST_TERMINATED;
    return FS_ST_OK;
}

int fs_inst_reset(fs_inst *inst)
{
    fs_fmu *m = fs_fmu_new();
    if (!m) {
        snprintf(inst->msg, sizeof(inst->msg), "reset: out of memory");
        return fail(inst, "logStatusError", FS_ST_ERROR);
    }
    fs_fmu_free(inst->m);
    inst->m = m;
    inst->t = inst->t_stop = 0.0;
    inst->state = FS_INST_INSTANTIATED;
    return FS_ST_OK;
}
