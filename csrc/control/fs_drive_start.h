/* The drive's internals shared by its files (not part of the public API):
 * the predicates on its configuration, and the start-up sequence
 * (fs_drive_start.c) that the hub (fs_drive.c) calls. */
#ifndef FS_DRIVE_START_H
#define FS_DRIVE_START_H

#include "fs_drive.h"

/* A refusal names the config field or sub-block at fault (fs_drive.fail). */
#define REFUSE(where, status) do { drv->fail = (where); return (status); } while (0)
#define SUB(where, call) do { fs_status st_ = (call); if (st_ != FS_OK) { REFUSE((where), st_); } } while (0)

static inline bool drive_starts(const fs_drive_config *c)
{
    return FS_WITH_IF_START && c->mode == (int)FS_MODE_SPEED && c->angle_source == (int)FS_ANGLE_SMO && c->i_start > 0.0f;
}

static inline bool drive_weakens(const fs_drive_config *c)
{
    return c->mode == (int)FS_MODE_SPEED && c->fw_w_e_max > 0.0f;
}

static inline bool drive_injects(const fs_drive_config *c)
{
    return c->angle_source == (int)FS_ANGLE_HFI || c->angle_source == (int)FS_ANGLE_BLEND;
}

/* The polarity by the motion test (fs_motion_test.h), or else by pulses. */
static inline bool drive_motion(const fs_drive_config *c) { return FS_WITH_MOTION_TEST && c->motion.i_push > 0.0f; }

/* The polarity is detected before the injection's start: by pulses or by the motion test. */
static inline bool drive_detects_polarity(const fs_drive_config *c)
{
    return c->polarity.i_pulse > 0.0f || drive_motion(c);
}

/* With an option off (fs_drive.h, FS_WITH_*) the predicate is constant false:
 * the compiler drops the code it guards and the linker its sub-blocks. */
static inline bool drive_square(const fs_drive_config *c) { return FS_WITH_SWVI && c->angle_source == (int)FS_ANGLE_SWVI; }

static inline bool drive_imc(const fs_drive_config *c) { return FS_WITH_IMC && c->converter == (int)FS_CONV_IMC; }

static inline bool drive_five(const fs_drive_config *c) { return FS_WITH_FIVE_PHASE && c->phases == 5; }

/* zou2021 PART_2: the depth controller runs in speed mode with flux weakening. */
static inline bool drive_imc_depth(const fs_drive_config *c)
{
    return drive_imc(c) && c->imc_depth && c->imc_region == (int)FS_IMC_OM2 && drive_weakens(c);
}

/* The loops' period: every other sample with the square wave (sec. 2.2). */
static inline float drive_loop_Ts(const fs_drive_config *c) { return drive_square(c) ? 2.0f * c->Ts : c->Ts; }

/* A flux map in the controller (constant false without FS_WITH_FLUXMAP: its code is not linked). */
/* the machine on its flux map (fs_drive.h, map) */
static inline bool drive_map(const fs_drive *drv) { return FS_WITH_FLUXMAP && drv->has_map && !drv->cfg.map_fw_only; }
/* the flux weakening planned on a map (the machine's, or the one its constants make) */
static inline bool drive_fw_plans(const fs_drive *drv) { return FS_WITH_FLUXMAP && drv->has_map; }

/* The SMO runs for its own source and inside the blend. */
static inline bool drive_has_smo(const fs_drive_config *c)
{
    return c->angle_source == (int)FS_ANGLE_SMO || c->angle_source == (int)FS_ANGLE_BLEND;
}

/* The controller's torque at a current (the motion observers' feed-forward). */
/* The torque of a dq current on the model, k_T (psi_f + (L_d - L_q) i_d) i_q
 * with k_T = phases/2 p; the step takes k_T formed once in init (fs_drive.k_T),
 * the same bits as formed here. */
static inline float drive_torque_k(const fs_drive_config *c) { return 0.5f * (float)c->phases * (float)c->pole_pairs; }

static inline float drive_torque_at(const fs_drive_config *c, float k_T, fs_dq i)
{
    return k_T * (c->psi_f + (c->L_d - c->L_q) * i.d) * i.q;
}

static inline float drive_torque(const fs_drive_config *c, fs_dq i) { return drive_torque_at(c, drive_torque_k(c), i); }

/* The start's functions run before the loops close (FS_COLD, fs_math.h:
 * kept apart from the step's code, which the firmware's link-time inlining
 * would otherwise grow past its limits: with them inlined the blended step
 * lost the monitor's inlining, +51 instructions a step on average).
 * The start's units from the config (fs_drive_init, after the injection's),
 * and their state afresh (fs_drive_reset). */
fs_status fs_drive_start_init(fs_drive *drv, const fs_drive_config *cfg);
void fs_drive_start_reset(fs_drive *drv);
/* The injection estimators' first step (polarity detection first when
 * sensorless, else their angle from the encoder). */
void fs_drive_start_estimators(fs_drive *drv, const fs_drive_in *in);
/* One step of the polarity detection (pulses or motion test): its current
 * reference; the run on its decision (the estimates turned by pi if it says
 * so), the halt on its refusal. */
fs_dq fs_drive_polarity_step(fs_drive *drv);
/* One step of the I/f start: its current reference, and the hand-over. */
fs_dq fs_drive_if_step(fs_drive *drv, const fs_drive_in *in, fs_ab i_ab);
/* Running on the observer: back to the I/f frame when its speed and the
 * reference are below w_restart. */
void fs_drive_if_restart(fs_drive *drv, const fs_drive_in *in);
/* The start sequence again after a loss of lock (false: none). */
bool fs_drive_restart(fs_drive *drv);

#endif /* FS_DRIVE_START_H */
