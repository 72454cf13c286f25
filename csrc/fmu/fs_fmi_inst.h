/* What the FMI 2.0 and 3.0 front ends (fs_fmi2.c, fs_fmi3.c) share: an
 * instance's state machine, the checks of a get or set against the
 * variables' types and causalities (fs_fmu_vars.h), and the step. The
 * statuses are those both standards number alike: OK 0, Warning 1,
 * Discard 2, Error 3. */
#ifndef FS_FMI_INST_H
#define FS_FMI_INST_H

#include <stddef.h>

#include "fs_fmu.h"

enum { FS_ST_OK = 0, FS_ST_WARNING = 1, FS_ST_DISCARD = 2, FS_ST_ERROR = 3 };

typedef enum {
    FS_INST_INSTANTIATED = 0,   /* parameters and inputs may be set */
    FS_INST_INITIALIZATION,     /* the same; its exit runs the model's init */
    FS_INST_STEP,               /* doStep; inputs may be set */
    FS_INST_STOPPED,            /* the closed loop stopped: only gets, terminate, reset, free */
    FS_INST_TERMINATED,
    FS_INST_ERROR               /* a failed init or step: only gets, reset, free */
} fs_inst_state;

typedef struct fs_inst fs_inst;
/* The front end's logger: the instance, an FMI status, a category, the message. */
typedef void fs_inst_log(fs_inst *inst, int status, const char *category, const char *message);

struct fs_inst {
    fs_fmu *m;
    fs_inst_state state;
    double t;                 /* the communication point, s */
    double t_stop;            /* where the closed loop stopped, s */
    int logging;              /* fmiXSetDebugLogging */
    fs_inst_log *log;
    void *front;              /* the front end's own (callbacks, environment) */
    char name[128];
    char msg[512];
};

/* A new instance in FS_INST_INSTANTIATED (NULL: no memory). */
fs_inst *fs_inst_new(const char *name, fs_inst_log *log, void *front, int logging);
void fs_inst_free(fs_inst *inst);
/* FS_ST_OK when value reference vr may be read (set = 0) or written
 * (set = 1) as type (FS_FMU_REAL, _INT, _BOOL) now; else logs why and
 * returns FS_ST_ERROR. */
int fs_inst_check(fs_inst *inst, unsigned vr, int type, int set);
/* The value of vr (the time for FS_VR_TIME), and its setter. */
double fs_inst_value(fs_inst *inst, unsigned vr);
void fs_inst_set(fs_inst *inst, unsigned vr, double value);
int fs_inst_enter_init(fs_inst *inst, double t_start);
int fs_inst_exit_init(fs_inst *inst);
/* One communication step from t of size h (one control period). */
int fs_inst_do_step(fs_inst *inst, double t, double h);
int fs_inst_terminate(fs_inst *inst);
/* Back to the start values, FS_INST_INSTANTIATED. */
int fs_inst_reset(fs_inst *inst);
/* Logs an unsupported call and returns FS_ST_ERROR. */
int fs_inst_unsupported(fs_inst *inst, const char *function);

#endif /* FS_FMI_INST_H */
