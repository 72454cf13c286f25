/* The model inside a fullspeed FMU, between the FMI front ends (fs_fmi2.c,
 * fs_fmi3.c: the standard's C API) and what it runs: the drive
 * (fs_fmu_drive.c: fs_drive_init and fs_drive_step on the exported
 * fs_drive_config) or the closed loop (fs_fmu_system.c: fs_sim on the
 * serialized fs_sim_config). One FMU is one front end and one model.
 *
 * Its variables are numbered by value reference. fs_fmu_vars.h is written
 * with the model description (fullspeed.workflows.fmu), from the same table:
 * FS_VR_<NAME> for every variable the model knows, FS_FMU_NV past the last,
 * and for each value reference its type in this FMU (0: not in this FMU's
 * model description, the scenario does not use it), its causality, its
 * start value and, for the closed loop, the trace channel it shows. Every
 * variable is held as a double (integers and Booleans exactly).
 *
 * The communication step is one control period, FS_FMU_TS: a doStep runs
 * one sample of the drive (its inputs as set before it) and, for the closed
 * loop, the plant over that period.
 *
 * fmi2/ and fmi3/ hold the FMI standard's headers as the Modelica
 * Association publishes them (2-Clause BSD, the licence at the head of each
 * file), copied unchanged from FMPy 0.3.32's package (fmpy/c-code); the
 * front ends are this project's own. */
#ifndef FS_FMU_H
#define FS_FMU_H

#include "fs_fmu_vars.h"

enum { FS_FMU_REAL = 1, FS_FMU_INT = 2, FS_FMU_BOOL = 3 };       /* fs_fmu_type[] */
enum { FS_FMU_INPUT = 1, FS_FMU_PARAMETER = 2, FS_FMU_OUTPUT = 3, FS_FMU_CONSTANT = 4 };   /* fs_fmu_causality[] */
enum { FS_FMU_OK = 0, FS_FMU_STOPPED = 1, FS_FMU_FAIL = 2 };     /* what fs_fmu_start and fs_fmu_step return */

typedef struct fs_fmu fs_fmu;

/* A new model with its variables at their start values; NULL: no memory. */
fs_fmu *fs_fmu_new(void);
void fs_fmu_free(fs_fmu *m);
/* Its variables, v[FS_FMU_NV]: the front end reads and writes them. */
double *fs_fmu_values(fs_fmu *m);
/* The end of initialization: the drive's (or the simulation's) init with
 * the parameters as set. FS_FMU_FAIL with the reason in msg. */
int fs_fmu_start(fs_fmu *m, char *msg, int len);
/* One control period from the inputs as set: FS_FMU_OK, FS_FMU_STOPPED (the
 * closed loop stopped: overcurrent, NaN, lock lost, polarity refused; the
 * outputs are those of the stop, the reason in msg) or FS_FMU_FAIL. */
int fs_fmu_step(fs_fmu *m, char *msg, int len);

#endif /* FS_FMU_H */
