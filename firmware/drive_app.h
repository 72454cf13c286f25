/* The board-neutral integration layer: ADC codes -> fs_drive_in, the drive
 * step, fs_drive_out -> compare registers, and the protection the drive
 * itself does not do (fs_drive.h, "Integration contract"). Board access goes
 * through board.h only.
 */
#ifndef DRIVE_APP_H
#define DRIVE_APP_H

#include "fs_drive.h"

/* The board's scaling and protection levels (not part of fs_drive_config:
 * they describe the sensors and the power stage, not the controller). */
typedef struct {
    float i_gain;                    /* A per ADC code; positive current flows from the inverter into the machine */
    float i_zero[FS_PHASES_MAX];     /* ADC code at zero current (measure it with the PWM off, app_calibrate) */
    float u_gain;                    /* V per ADC code */
    float enc_counts;                /* encoder counts per mechanical turn */
    float enc_offset;                /* rad (mech.): the encoder's reading with the rotor's d axis (magnet
                                        north) on phase a's axis, where the drive's theta_e is 0 */
    float i_trip;                    /* A: |phase current| above it turns the PWM off at once (the drive has no trip) */
    float u_dc_min, u_dc_max;        /* V: outside, the PWM is turned off */
    float ramp;                      /* rad/s per s (mech.): the speed reference's largest rate (fs_drive.h,
                                        "References"; 0: none, the reference steps) */
} app_config;

typedef enum {
    APP_RUN = 0,
    APP_FAULT_OVERCURRENT = 1,
    APP_FAULT_UNDERVOLTAGE = 2,
    APP_FAULT_OVERVOLTAGE = 3,
    APP_FAULT_LOCK = 4,              /* lock lost and not re-acquired: lock_lost (fs_lock.h, fs_drive_protect.h) */
    APP_STOPPED = 5,                 /* not started, or app_stop */
    APP_FAULT_DRIVE = 6              /* the drive halted: app.out.fault (fs_drive_fault), e.g. the
                                        polarity detection could not decide, or its overspeed */
} app_state;

/* app_init's refusal beside fs_drive_init's (an fs_status): the board's
 * timer cannot make the configuration's carrier period */
#define APP_ERR_PWM (-1)

typedef struct {
    fs_drive drive;
    app_config cfg;
    fs_drive_in in;
    fs_drive_out out;                /* the last step's, for telemetry */
    float dw_ref;                    /* the reference's largest step per interrupt, rad/s (ramp Ts) */
    /* written by the application outside the interrupt (32-bit stores: atomic on a Cortex-M) */
    volatile float w_m_ref;          /* rad/s mechanical: the target, approached at cfg.ramp */
    volatile int sensorless;
    volatile int state;              /* app_state, written by the interrupt */
} drive_app;

/* fs_drive_init on the (exported) configuration and the board's carrier at
 * its T_pwm; 0 on success, else the fs_status (app->drive.fail names the
 * field) or APP_ERR_PWM. The PWM stays off. */
int app_init(drive_app *app, const fs_drive_config *cfg, const app_config *board);
/* Average n conversions with the PWM off into cfg.i_zero (call before app_start). */
void app_calibrate(drive_app *app, int n);
/* Reset the drive's state, preload duties of 1/2 and turn the PWM on; the
 * next interrupt steps it. */
void app_start(drive_app *app);
void app_stop(drive_app *app);
/* The PWM update interrupt. */
void app_pwm_isr(drive_app *app);

#endif /* DRIVE_APP_H */
