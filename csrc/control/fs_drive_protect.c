/* The drive's protection: the answer to a loss of lock (the zero-current
 * wait, then the flying restart, the start sequence again or the halt) and
 * the overspeed stop (fs_drive_protect.h); the hub (fs_drive.c) calls these. */
#include "fs_drive_protect.h"
#include "fs_drive_start.h"
#include "fs_math.h"

#include <stddef.h>

FS_COLD void fs_drive_halt(fs_drive *drv, int fault, fs_drive_out *out)
{
    drv->phase = FS_PHASE_HALT;
    drv->fault = fault;
    if (!out) { return; }
    for (int k = 0; k < drv->cfg.phases; ++k) { out->duty[k] = 0.5f; }
    out->phase = FS_PHASE_HALT;
    out->fault = fault;
}

/* The back-EMF observer tracks the rotor: valid, converged (its residuals
 * settled, its speed agreeing with its EMF's: fs_smo.h) and, in the blend,
 * above w_lower (below it the blend would hand it to the injection). */
static bool drive_smo_catches(const fs_drive *drv)
{
    const fs_drive_config *c = &drv->cfg;
    if (!drive_has_smo(c) || !drv->smo.valid || !drv->smo.converged) { return false; }
    return c->angle_source != (int)FS_ANGLE_BLEND || fabsf(drv->smo.w) >= drv->blend.cfg.w_lower;
}

/* Every estimate takes the observer's angle and speed. */
static void drive_catch(fs_drive *drv)
{
    if (drv->cfg.angle_source != (int)FS_ANGLE_BLEND) { return; }
    fs_blend_reset(&drv->blend, drv->smo.theta, drv->smo.w);
    fs_hfi_set_angle(&drv->hfi, drv->smo.theta, drv->smo.w);
}

/* The speed below which the back-EMF observer is not trusted, el. rad/s:
 * there the start sequence finds the rotor again (none with the
 * injection alone: its estimator is the only one, at any speed). */
static float drive_w_low(const fs_drive_config *c)
{
    if (c->angle_source == (int)FS_ANGLE_BLEND) { return c->blend.w_lower; }
    if (c->angle_source == (int)FS_ANGLE_HFI) { return FS_DRIVE_NO_LIMIT; }
    return drive_starts(c) ? c->w_handover : c->smo.w_valid;
}

static void drive_recover_begin(fs_drive *drv)
{
    const fs_drive_config *c = &drv->cfg;
    drv->phase = FS_PHASE_RECOVER;
    drv->t_left = c->t_recover;
    drv->recoveries += 1;
    drv->w_over = FS_DRIVE_NO_LIMIT;   /* the estimate is lost: its speed means nothing until re-acquired */
    drv->e_rec = 0.0f;
    fs_lock_reset(&drv->lock);   /* the residual's low-passes restart out of FS_PHASE_RUN */
    if (c->mode == (int)FS_MODE_SPEED) { fs_speed_ctrl_reset(&drv->sc); }
    if (drive_weakens(c)) { fs_fw_reset(&drv->fw); }
    if (drive_smo_catches(drv)) { drive_catch(drv); }
}

FS_COLD void fs_drive_lock_lost(fs_drive *drv, fs_drive_out *out)
{
    if (drv->recoveries < drv->cfg.lock_retries) {
        drive_recover_begin(drv);
        out->lock_lost = false;
    } else {
        fs_drive_halt(drv, FS_FAULT_LOCK, out);
    }
}

/* The end of the wait (fs_drive_protect.h, 2.), on the EMF's magnitude E. */
static void drive_recover_end(fs_drive *drv, float E)
{
    const fs_drive_config *c = &drv->cfg;
    drv->phase = FS_PHASE_RUN;
    drv->w_over = c->w_over > 0.0f ? c->w_over : FS_DRIVE_NO_LIMIT;
    if (drive_smo_catches(drv)) {   /* the flying restart */
        drive_catch(drv);
        if (c->mode == (int)FS_MODE_SPEED) { fs_speed_ctrl_preset(&drv->sc, drv->smo.w / (float)c->pole_pairs, 0.0f); }
    } else if (!(E < drive_w_low(c) * c->psi_f) || !fs_drive_restart(drv)) {
        fs_drive_halt(drv, FS_FAULT_LOCK, NULL);
    } else {
        /* the EMF is low: fs_drive_restart has begun the start sequence again */
    }
}

FS_COLD void fs_drive_recover_step(fs_drive *drv, fs_ab i_ab)
{
    const fs_drive_config *c = &drv->cfg;
    /* the EMF over the period that ended now, e = u - R i: the loops hold i
     * near 0, and their ripple's L di/dt (the current sensors' noise times
     * L / Ts) would outweigh what it corrects */
    const fs_ab u = drive_u_past(drv);
    const float e_a = u.alpha - c->R_s * i_ab.alpha, e_b = u.beta - c->R_s * i_ab.beta;
    drv->e_rec += (1.0f - drv->lock_a) * (sqrtf(e_a * e_a + e_b * e_b) - drv->e_rec);   /* over lock_time / 4 */
    drv->t_left -= c->Ts;
    if (drv->t_left <= 0.0f) { drive_recover_end(drv, drv->e_rec); }
}
