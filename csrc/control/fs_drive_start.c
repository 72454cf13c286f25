/* The drive's start-up sequence (polarity detection, the injection
 * estimators' first step, the I/f start and its hand-over), also run again
 * after a loss of lock at low speed; the hub (fs_drive.c) and the protection
 * (fs_drive_protect.c) call these. */
#include "fs_drive_start.h"
#include "fs_math.h"

/* The injection estimators' first step: sensorless from the start, the
 * polarity is detected first; with the encoder in the loop they start from
 * its angle (commissioning, calibration). */
void fs_drive_start_estimators(fs_drive *drv, const fs_drive_in *in)
{
    const fs_drive_config *c = &drv->cfg;
    drv->est_started = true;
    if (in->sensorless) {
        bool closed_loop = c->mode == FS_MODE_CURRENT || c->mode == FS_MODE_SPEED;
        if (closed_loop && c->polarity.i_pulse > 0.0f) drv->phase = FS_PHASE_POLARITY;
        return;
    }
    float theta = fs_wrap_pi((float)c->pole_pairs * in->theta_m_enc);
    fs_hfi_set_angle(&drv->hfi, theta, 0.0f);
    if (c->angle_source == FS_ANGLE_BLEND) fs_blend_reset(&drv->blend, theta, 0.0f);
}

/* Polarity found: turn the estimates by pi if they point at the south pole. */
void fs_drive_polarity_done(fs_drive *drv)
{
    if (drv->pol.flip) {
        const float theta = fs_wrap_pi(drv->hfi.theta + FS_PI), T_d = drv->hfi.obs.T_d_hat;
        fs_hfi_set_angle(&drv->hfi, theta, drv->hfi.w);
        fs_hfi_set_load(&drv->hfi, T_d);   /* the load does not turn with the estimate */
        if (drv->cfg.angle_source == FS_ANGLE_BLEND) {
            fs_blend_reset(&drv->blend, theta, drv->hfi.w);
            drv->blend.obs.T_d_hat = T_d;
        }
    }
    if (drv->cfg.mode == FS_MODE_SPEED) fs_speed_ctrl_reset(&drv->sc);
    drv->phase = FS_PHASE_RUN;
}

/* I/f start: the frame accelerates towards the reference, or up to the
 * hand-over speed, with i_start on its d axis; the rotor's d axis lags the
 * current by the load angle at which the torque carries the load and the
 * acceleration (self-synchronising, and at standstill the current aligns the
 * rotor without torque). The observer is told the frame's direction (it has
 * no EMF to take it from at standstill). The loops take the observer once
 * the frame is at the hand-over speed and the observer has converged: valid,
 * its residuals settled (fs_smo.h: `converged`, the current error inside the
 * boundary layer and the angle error under 5 el.deg for 4 / bw_pll) and its
 * speed within a quarter of the frame's (the rotor swings about the frame,
 * a mislocked observer is far off). Until then the frame holds the hand-over
 * speed. The speed controller's integral is preset to the torque the
 * current makes in the observer's frame, so that the hand-over does not bump
 * the torque. */
fs_dq fs_drive_if_step(fs_drive *drv, const fs_drive_in *in, fs_ab i_ab)
{
    const fs_drive_config *c = &drv->cfg;
    float w_target = fs_clamp_sym((float)c->pole_pairs * in->w_m_ref, c->w_handover);
    float dw = c->a_start * c->Ts;
    drv->w_if += fs_clamp_sym(w_target - drv->w_if, dw);
    drv->theta_if = fs_wrap_pi(drv->theta_if + c->Ts * drv->w_if);
    fs_smo_set_dir(&drv->smo, drv->w_if);
    fs_dq i_ref = {c->i_start, 0.0f};
    const bool fast = fabsf(drv->w_if) >= c->w_handover * 0.999f;
    const bool agree = drv->smo.w * drv->w_if > 0.0f && fabsf(drv->smo.w - drv->w_if) <= 0.25f * fabsf(drv->w_if);
    if (fast && drv->smo.valid && drv->smo.converged && agree) {
        fs_dq i_o = fs_park(i_ab, fs_cosf(drv->smo.theta), fs_sinf(drv->smo.theta));
        fs_speed_ctrl_preset(&drv->sc, drv->smo.w / (float)c->pole_pairs, drive_torque(c, i_o));
        drv->phase = FS_PHASE_RUN;
    }
    return i_ref;
}

/* The start sequence again, after a loss of lock at low speed
 * (fs_drive_protect.h): polarity detection on the injection estimator,
 * which kept following the saliency, or the I/f start; false without one
 * (the SMO started on the encoder). */
FS_COLD bool fs_drive_restart(fs_drive *drv)
{
    const fs_drive_config *c = &drv->cfg;
    if (drive_injects(c)) {
        drv->inject_on = true;
        if (c->angle_source == FS_ANGLE_BLEND) fs_blend_reset(&drv->blend, drv->hfi.theta, drv->hfi.w);
        if (c->polarity.i_pulse > 0.0f) {
            fs_polarity_reset(&drv->pol);
            drv->phase = FS_PHASE_POLARITY;
        }
        return true;
    }
    if (drive_starts(c)) {
        drv->theta_if = drv->smo.theta;
        drv->w_if = 0.0f;
        drv->phase = FS_PHASE_START;
        return true;
    }
    return false;
}
