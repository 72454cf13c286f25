/* The drive's start-up sequence (polarity detection by pulses or by a
 * bounded motion, the injection estimators' first step, the I/f start, its
 * hand-over and its return at low speed), also run again after a loss of
 * lock at low speed; the hub (fs_drive.c) and the protection
 * (fs_drive_protect.c) call these. */
#include "fs_drive_start.h"
#include "fs_drive_protect.h"
#include "fs_math.h"

#include <stddef.h>

/* The injection estimators' first step: sensorless from the start, the
 * polarity is detected first; with the encoder in the loop they start from
 * its angle (commissioning, calibration). */
FS_COLD void fs_drive_start_estimators(fs_drive *drv, const fs_drive_in *in)
{
    const fs_drive_config *c = &drv->cfg;
    drv->est_started = true;
    if (in->sensorless != 0) {
        bool closed_loop = c->mode == (int)FS_MODE_CURRENT || c->mode == (int)FS_MODE_SPEED;
        if (closed_loop && drive_detects_polarity(c)) { drv->phase = FS_PHASE_POLARITY; }
        return;
    }
    float theta = fs_wrap_pi((float)c->pole_pairs * in->theta_m_enc);
    fs_hfi_set_angle(&drv->hfi, theta, 0.0f);
    if (c->angle_source == (int)FS_ANGLE_BLEND) { fs_blend_reset(&drv->blend, theta, 0.0f); }
}

/* The start's units: the polarity detection (pulses or the motion test;
 * after the injection's init, whose carrier bounds them) and the I/f start. */
FS_COLD fs_status fs_drive_start_init(fs_drive *drv, const fs_drive_config *cfg)
{
    if (cfg->polarity.i_pulse > 0.0f && cfg->motion.i_push > 0.0f) { REFUSE("motion.i_push", FS_ERR_PARAM); }   /* one method */
    if (!FS_WITH_MOTION_TEST && cfg->motion.i_push > 0.0f) { REFUSE("motion", FS_ERR_MODE); }   /* left out (fs_drive.h) */
    if (!FS_WITH_IF_START && cfg->i_start > 0.0f) { REFUSE("i_start", FS_ERR_MODE); }
    if (drive_injects(cfg) && cfg->polarity.i_pulse > 0.0f) {
        fs_polarity_config pc = cfg->polarity;
        pc.Ts = cfg->Ts;
        if (pc.i_pulse > cfg->i_max) { REFUSE("polarity.i_pulse", FS_ERR_ABOVE_I_MAX); }
        if (pc.i_pulse_max > cfg->i_max) { REFUSE("polarity.i_pulse_max", FS_ERR_ABOVE_I_MAX); }
        /* the retries up to the current limit less the carrier's peak */
        if (pc.i_pulse_max == 0.0f) { pc.i_pulse_max = fs_maxf(cfg->i_max - drv->i_hf, pc.i_pulse); }
        pc.w_filter = drv->hfi.cfg.w_b_p;
        const float carrier_steps = (2.0f * FS_PI / (drv->hfi.cfg.w_h * cfg->Ts)) + 0.5f;   /* rounded by the truncation */
        pc.n_carrier = (int)carrier_steps;
        SUB("polarity", fs_polarity_init(&drv->pol, &pc));
    }
    if (drive_injects(cfg) && drive_motion(cfg)) {
        fs_motion_test_config mc = cfg->motion;
        mc.Ts = cfg->Ts;
        /* the injection's filters settle (fs_hfi.h), and its observer, a triple pole, catches up (1.4 % left) */
        mc.t_settle = (float)drv->hfi.n_settle * cfg->Ts + 8.0f / drv->hfi.cfg.obs.bandwidth;
        if (!(mc.i_push_max <= cfg->i_max - drv->i_hf && mc.i_push <= cfg->i_max - drv->i_hf)) {
            REFUSE("motion.i_push", FS_ERR_ABOVE_I_MAX);   /* with the carrier's peak, within i_max */
        }
        SUB("motion", fs_motion_test_init(&drv->mt, &mc));
    }
    if (cfg->i_start > cfg->i_max) { REFUSE("i_start", FS_ERR_ABOVE_I_MAX); }
    if (FS_WITH_IF_START && cfg->i_start > 0.0f) {
        if (!fs_pos(cfg->a_start)) { REFUSE("a_start", FS_ERR_PARAM); }
        if (!fs_pos(cfg->w_handover)) { REFUSE("w_handover", FS_ERR_PARAM); }
        if (!(fs_nonneg(cfg->w_restart) && cfg->w_restart < cfg->w_handover)) { REFUSE("w_restart", FS_ERR_PARAM); }
        fs_if_start_config ic = {cfg->Ts, cfg->i_start, cfg->a_start, cfg->w_handover, cfg->R_s,
                                 0.5f * (cfg->L_d + cfg->L_q), cfg->psi_f, cfg->r_damp, cfg->w_swing, cfg->i_max,
                                 cfg->t_handover};
        SUB("r_damp, w_swing, t_handover", fs_if_start_init(&drv->ifs, &ic));
    }
    return FS_OK;
}

/* The start's state afresh (fs_drive_reset). */
FS_COLD void fs_drive_start_reset(fs_drive *drv)
{
    const fs_drive_config *c = &drv->cfg;
    if (drive_injects(c) && c->polarity.i_pulse > 0.0f) { fs_polarity_reset(&drv->pol); }
    if (drive_injects(c) && drive_motion(c)) { fs_motion_test_reset(&drv->mt); }
    if (FS_WITH_IF_START && c->i_start > 0.0f) { fs_if_start_reset(&drv->ifs, 0.0f, 0.0f); }
    drv->mt_ff = 0.0f;
    drv->hfi_aligned = false;
    drv->fault = FS_FAULT_NONE;
}

/* The polarity stage's first settled step: the estimate set on the
 * saliency's axis from the carrier's own angle (fs_hfi_axis_error), not
 * left to the observer's pull-in, which from near 90 el.deg off (the
 * saliency's unstable equilibrium, where eq. (26)'s sin 2 dtheta vanishes)
 * takes arbitrarily long: SyR-e's THOR started 90 el.deg from its estimate
 * pulled in over 80 ms, overshooting, and its light rotor (J = 0.0042 kg
 * m^2) drifted at 6 rpm from the transient's torque, which made the motion
 * test wait a second lock into the load's arrival and refuse. */
static void drive_hfi_align(fs_drive *drv)
{
    const float theta = fs_wrap_pi(drv->hfi.theta + fs_hfi_axis_error(&drv->hfi));
    fs_hfi_set_angle(&drv->hfi, theta, 0.0f);
    if (drv->cfg.angle_source == (int)FS_ANGLE_BLEND) { fs_blend_reset(&drv->blend, theta, 0.0f); }
    drv->hfi_aligned = true;
}

/* Polarity found: turn the estimates by pi if they point at the south pole. */
static void drive_polarity_done(fs_drive *drv, bool flip, float t_quiet)
{
    if (flip) {
        const float theta = fs_wrap_pi(drv->hfi.theta + FS_PI), T_d = drv->hfi.obs.T_d_hat;
        fs_hfi_set_angle(&drv->hfi, theta, drv->hfi.w);
        fs_hfi_set_load(&drv->hfi, T_d);   /* the load does not turn with the estimate */
        if (drv->cfg.angle_source == (int)FS_ANGLE_BLEND) {
            fs_blend_reset(&drv->blend, theta, drv->hfi.w);
            drv->blend.obs.T_d_hat = T_d;
        }
    }
    if (drv->cfg.mode == (int)FS_MODE_SPEED) { fs_speed_ctrl_reset(&drv->sc); }
    /* the lock's checks start once the estimate has settled (t_quiet): the
     * loops' angle that turned by pi is not a jump (fs_monitor.h, 4.) */
    drv->t_quiet = t_quiet;
    drv->phase = FS_PHASE_RUN;
}

/* The motion test's push leaves the observers' torque feed-forward as it was
 * (fs_motion_test.h): each change of the torque the loops will feed forward
 * (drive_torque_at with i_d = 0, the same bits) is taken out of their load
 * estimates, and put back as the push ends. */
static void drive_motion_ff(fs_drive *drv, float i_q)
{
    const float T = drv->k_T * drv->cfg.psi_f * i_q, dT = T - drv->mt_ff;
    if (dT == 0.0f) { return; }
    drv->mt_ff = T;
    drv->hfi.obs.T_d_hat -= dT;
    if (drv->cfg.hfi.lag != 0) { drv->hfi.obs_w.T_d_hat -= dT; }
    if (drv->cfg.angle_source == (int)FS_ANGLE_BLEND) { drv->blend.obs.T_d_hat -= dT; }
}

/* One step of the polarity detection: the d-current pulses or the motion
 * test's q current (on the injection's estimated axis); on its decision the
 * run, on its refusal the halt. */
FS_COLD fs_dq fs_drive_polarity_step(fs_drive *drv)
{
    fs_dq i_ref = {0.0f, 0.0f};
    if (!drv->hfi_aligned && (drv->hfi.k_settle == 0) && (drv->hfi.gain >= 1.0f)) { drive_hfi_align(drv); }
    if (drive_motion(&drv->cfg)) {
        i_ref.q = fs_motion_test_step(&drv->mt, drv->hfi.theta);
        drive_motion_ff(drv, i_ref.q);
        if (drv->mt.stage == (int)FS_MOTION_DONE) {   /* it ends on a settled estimate: its turn is read with no current */
            drive_polarity_done(drv, drv->mt.flip, 2.0f * drv->cfg.Ts);
        }
        if (drv->mt.stage == (int)FS_MOTION_UNDETERMINED) { fs_drive_halt(drv, FS_FAULT_POLARITY, NULL); }
        return i_ref;
    }
    i_ref.d = fs_polarity_step(&drv->pol, drv->hfi.i_p, drv->hfi.w);
    /* the pulses saturated the d axis and turned the rotor: the estimate comes
     * back within the estimator's settling time, the wait before the pulses
     * (polarity.t_lock), and only then does its error say whether it tracks
     * (a saturating 30 kW traction machine: 24 el.deg off after its 74 A
     * pulses, back within 30 ms) */
    if (drv->pol.stage == (int)FS_POLARITY_DONE) { drive_polarity_done(drv, drv->pol.flip, fs_maxf(drv->cfg.polarity.t_lock, 2.0f * drv->cfg.Ts)); }
    if (drv->pol.stage == (int)FS_POLARITY_UNDETERMINED) { fs_drive_halt(drv, FS_FAULT_POLARITY, NULL); }
    return i_ref;
}

/* I/f start (fs_if_start.h): the frame accelerates towards the reference,
 * or up to the hand-over speed, with i_start on its d axis and the damping;
 * the rotor's d axis lags the current by the load angle at which the torque
 * carries the load and the acceleration (self-synchronising, and at
 * standstill the current aligns the rotor). The observer is told the frame's
 * direction (it has no EMF to take it from at standstill). The loops take
 * the observer once the frame is at the hand-over speed and the observer has
 * converged: valid, its residuals settled (fs_smo.h: `converged`, the
 * current error inside the boundary layer and the angle error under 5 el.deg
 * for 4 / bw_pll) and its speed within a quarter of the frame's (the rotor
 * swings about the frame, a mislocked observer is far off). Until then the
 * frame holds the hand-over speed, at most t_handover (then the drive halts:
 * FS_FAULT_START). The speed controller's integral is preset to the torque
 * the current makes in the observer's frame, so that the hand-over does not
 * bump the torque. */
FS_COLD fs_dq fs_drive_if_step(fs_drive *drv, const fs_drive_in *in, fs_ab i_ab)
{
    const fs_drive_config *c = &drv->cfg;
    fs_if_start *s = &drv->ifs;
    const fs_dq i_ref = fs_if_start_step(s, (float)c->pole_pairs * in->w_m_ref, i_ab, drive_u_past(drv));
    fs_smo_set_dir(&drv->smo, s->w);
    const bool fast = fabsf(s->w) >= c->w_handover * 0.999f;
    const bool agree = drv->smo.w * s->w > 0.0f && fabsf(drv->smo.w - s->w) <= 0.25f * fabsf(s->w);
    if (fast && drv->smo.valid && drv->smo.converged && agree) {
        fs_dq i_o = fs_park(i_ab, fs_cosf(drv->smo.theta), fs_sinf(drv->smo.theta));
        fs_speed_ctrl_preset(&drv->sc, drv->smo.w / (float)c->pole_pairs, drive_torque(c, i_o));
        drv->phase = FS_PHASE_RUN;
    } else if (s->timed_out) {
        fs_drive_halt(drv, FS_FAULT_START, NULL);
    } else {
        /* the I/f start goes on: the observer has not yet agreed */
    }
    return i_ref;
}

/* Back to the I/f frame from the observer (w_restart > 0): the loops run on
 * it at a speed it is still trusted at and the reference asks to stay below
 * that too (a reversal: the speeds near zero where it is blind come next).
 * The frame starts on the observer's angle and speed, turned ahead by the
 * load angle at which i_start makes the torque the loops made (at most 45
 * el.deg: the design's), so that the torque does not jump. */
FS_COLD void fs_drive_if_restart(fs_drive *drv, const fs_drive_in *in)
{
    const fs_drive_config *c = &drv->cfg;
    const float w_ref = (float)c->pole_pairs * in->w_m_ref;
    if (!(fabsf(drv->smo.w) < c->w_restart && fabsf(w_ref) < c->w_restart)) { return; }
    const float T_i = drv->k_T * c->psi_f * c->i_start;
    const float sd = T_i > 0.0f ? fs_clamp_sym(drv->T_ff / T_i, 0.70710678f) : 0.0f;
    fs_if_start_reset(&drv->ifs, fs_wrap_pi(drv->smo.theta + fs_atan2f(sd, sqrtf(1.0f - sd * sd))), drv->smo.w);
    drv->phase = FS_PHASE_START;
}

/* The start sequence again, after a loss of lock at low speed
 * (fs_drive_protect.h): polarity detection (pulses or the motion test) on
 * the injection estimator, which kept following the saliency, or the I/f
 * start; false without one (the SMO started on the encoder). */
FS_COLD bool fs_drive_restart(fs_drive *drv)
{
    const fs_drive_config *c = &drv->cfg;
    if (drive_injects(c)) {
        drv->inject_on = true;
        if (c->angle_source == (int)FS_ANGLE_BLEND) { fs_blend_reset(&drv->blend, drv->hfi.theta, drv->hfi.w); }
        if (drive_detects_polarity(c)) {
            fs_drive_start_reset(drv);
            drv->phase = FS_PHASE_POLARITY;
        }
        return true;
    }
    if (drive_starts(c)) {
        fs_if_start_reset(&drv->ifs, drv->smo.theta, 0.0f);
        drv->phase = FS_PHASE_START;
        return true;
    }
    return false;
}
