#include "drive_app.h"
#include "board.h"

#include <math.h>

int app_init(drive_app *app, const fs_drive_config *cfg, const app_config *board)
{
    board_pwm(false);
    app->state = APP_STOPPED;
    app->cfg = *board;
    app->in = (fs_drive_in){0};
    app->w_m_ref = 0.0f;
    app->sensorless = 0;
    const int st = (int)fs_drive_init(&app->drive, cfg);
    if (st != 0) return st;
    app->dw_ref = board->ramp > 0.0f ? board->ramp * cfg->Ts : INFINITY;
    return board_pwm_init(cfg->T_pwm) ? 0 : APP_ERR_PWM;
}

void app_calibrate(drive_app *app, int n)
{
    float sum[FS_PHASES_MAX] = {0};
    board_sample s;
    for (int j = 0; j < n; ++j) {
        board_read(&s);   /* a real board waits for the next conversion here */
        for (int k = 0; k < FS_PHASES_MAX; ++k) sum[k] += (float)s.i_ph[k];
    }
    for (int k = 0; k < FS_PHASES_MAX; ++k) app->cfg.i_zero[k] = n > 0 ? sum[k] / (float)n : 0.0f;
}

void app_start(drive_app *app)
{
    static const float half[FS_PHASES_MAX] = {0.5f, 0.5f, 0.5f, 0.5f, 0.5f};
    fs_drive_reset(&app->drive);   /* the sequence starts over: polarity detection, injection, ... */
    app->in.w_m_ref = 0.0f;        /* the ramp starts from standstill */
    board_set_duty(half, app->drive.cfg.phases);   /* the zero vector's mean until the first step's duties */
    board_pwm(true);
    app->state = APP_RUN;          /* last: no step runs before the PWM is on */
}

void app_stop(drive_app *app)
{
    board_pwm(false);
    app->state = APP_STOPPED;
}

static void app_fault(drive_app *app, app_state why)
{
    board_pwm(false);   /* first: the switches open */
    app->state = why;
}

void app_pwm_isr(drive_app *app)
{
    const app_config *c = &app->cfg;
    const int n = app->drive.cfg.phases;
    board_sample s;
    board_read(&s);
    float i_peak = 0.0f;
    for (int k = 0; k < n; ++k) {
        app->in.i_ph[k] = ((float)s.i_ph[k] - c->i_zero[k]) * c->i_gain;
        const float a = fabsf(app->in.i_ph[k]);
        if (a > i_peak) i_peak = a;   /* not fmaxf: a call on a Cortex-M4F (no max instruction) */
    }
    app->in.u_dc = (float)s.u_dc * c->u_gain;
    /* any range will do (fs_drive.h): the drive wraps p theta_m_enc itself */
    app->in.theta_m_enc = (float)s.enc * (6.2831853f / c->enc_counts) - c->enc_offset;
    app->in.sensorless = app->sensorless;
    if (app->state != APP_RUN) return;
    const float dw = app->w_m_ref - app->in.w_m_ref;   /* the reference, ramped (fs_drive.h, "References") */
    app->in.w_m_ref += dw > app->dw_ref ? app->dw_ref : (dw < -app->dw_ref ? -app->dw_ref : dw);
    if (i_peak > c->i_trip) {
        app_fault(app, APP_FAULT_OVERCURRENT);
        return;
    }
    if (app->in.u_dc < c->u_dc_min || app->in.u_dc > c->u_dc_max) {
        app_fault(app, app->in.u_dc < c->u_dc_min ? APP_FAULT_UNDERVOLTAGE : APP_FAULT_OVERVOLTAGE);
        return;
    }
    fs_drive_step(&app->drive, &app->in, &app->out);
    if (app->out.lock_lost) {   /* lost, and not re-acquired (fs_drive_protect.h): it will not go on */
        app_fault(app, APP_FAULT_LOCK);
        return;
    }
    if (app->out.fault != FS_FAULT_NONE) {   /* the drive halted (overspeed, polarity undetermined, an I/f start never handed over) */
        app_fault(app, APP_FAULT_DRIVE);
        return;
    }
    board_set_duty(app->out.duty, n);
}
