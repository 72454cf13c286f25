/* The firmware's integration layer (firmware/drive_app.c) on the host, over
 * a recording board instead of board_stub.c, with the exported
 * configuration (firmware/fs_config.c): what drive_app.h and the contract in
 * fs_drive.h promise. tests/test_firmware_app.py builds and runs it; it
 * prints one line per failed check and exits non-zero on any. */
#include <math.h>
#include <stdio.h>

#include "board.h"
#include "drive_app.h"
#include "fs_config.h"

static int failures;
#define CHECK(cond, ...) do { if (!(cond)) { ++failures; printf("FAILED %s: ", #cond); printf(__VA_ARGS__); printf("\n"); } } while (0)

/* the board: what the layer asked of it, in order */
static float pwm_T;            /* the carrier it was set up for */
static int pwm_ok = 1;         /* whether the timer can make it */
static int pwm_on;
static int calls, call_pwm_on, call_duty_half;   /* the order of app_start's calls */
static float duty_last[FS_PHASES_MAX];
static int state_at_pwm_on = -1;
static drive_app app;
static uint16_t adc_code = 2048;   /* every phase; 2048 = 0 A with the offset measured */

bool board_pwm_init(float T_pwm) { pwm_T = T_pwm; return pwm_ok; }

void board_read(board_sample *s)
{
    for (int k = 0; k < FS_PHASES_MAX; ++k) s->i_ph[k] = adc_code;
    s->u_dc = 1638;   /* 24 V at 0.0146484375 V per code */
    s->enc = 0;
}

void board_set_duty(const float duty[], int phases)
{
    ++calls;
    for (int k = 0; k < phases; ++k) duty_last[k] = duty[k];
    if (duty[0] == 0.5f && duty[1] == 0.5f && duty[2] == 0.5f && !call_duty_half) call_duty_half = calls;
}

void board_pwm(bool on)
{
    ++calls;
    pwm_on = on;
    if (on) {
        call_pwm_on = calls;
        state_at_pwm_on = app.state;
    }
}

static const app_config BOARD = {
    .i_gain = 0.048828125f, .u_gain = 0.0146484375f, .enc_counts = 4096.0f, .enc_offset = 0.0f,
    .i_trip = 75.0f, .u_dc_min = 18.0f, .u_dc_max = 30.0f, .ramp = 192.0f,
};

int main(void)
{
    /* a timer that cannot make the carrier: refused, the PWM off */
    pwm_ok = 0;
    CHECK(app_init(&app, &fs_config, &BOARD) == APP_ERR_PWM && !pwm_on, "a refused carrier");
    pwm_ok = 1;
    CHECK(app_init(&app, &fs_config, &BOARD) == 0, "init");
    CHECK(pwm_T == fs_config.T_pwm, "the board's carrier %g s is the configuration's %g s", pwm_T, fs_config.T_pwm);
    app_calibrate(&app, 8);
    CHECK(app.cfg.i_zero[0] == 2048.0f, "offsets measured: %g", app.cfg.i_zero[0]);

    /* start: duties of 1/2 preloaded, then the PWM on, and only then RUN */
    calls = call_pwm_on = call_duty_half = 0;
    app.sensorless = 1;
    app.w_m_ref = 460.8f;
    app_start(&app);
    CHECK(pwm_on && app.state == APP_RUN, "running");
    CHECK(call_duty_half > 0 && call_duty_half < call_pwm_on, "duties 1/2 (call %d) before the PWM on (call %d)",
          call_duty_half, call_pwm_on);
    CHECK(state_at_pwm_on != APP_RUN, "no step before the PWM is on (state %d when it went on)", state_at_pwm_on);

    /* the reference is ramped at BOARD.ramp: ramp Ts a step */
    for (int k = 0; k < 100; ++k) app_pwm_isr(&app);
    const float want = 100.0f * BOARD.ramp * fs_config.Ts;
    CHECK(fabsf(app.in.w_m_ref - want) <= 1e-4f * want, "ramped to %g rad/s after 100 steps, want %g", app.in.w_m_ref, want);
    CHECK(app.state == APP_RUN, "still running after 100 steps: %d", app.state);

    /* no machine on the terminals (zero current): the polarity detection
     * cannot decide, the drive halts with FS_FAULT_POLARITY, and the layer
     * turns the PWM off and says why */
    int k = 0;
    while (app.state == APP_RUN && k < 100000) {
        app_pwm_isr(&app);
        ++k;
    }
    CHECK(app.state == APP_FAULT_DRIVE && app.out.fault == FS_FAULT_POLARITY && !pwm_on,
          "halted on the polarity: state %d, fault %d, pwm %d after %d steps", app.state, app.out.fault, pwm_on, k);
    const int steps_fault = k;

    /* an overcurrent sample trips before the step */
    app_start(&app);
    adc_code = 4095;   /* honest codes: 2047 x 0.0488 A = 100 A */
    app_pwm_isr(&app);
    CHECK(app.state == APP_FAULT_OVERCURRENT && !pwm_on, "overcurrent: state %d", app.state);
    adc_code = 2048;

    /* app_stop: off; the interrupt then leaves the drive alone */
    app_start(&app);
    app_stop(&app);
    app_pwm_isr(&app);
    CHECK(app.state == APP_STOPPED && !pwm_on, "stopped: state %d", app.state);

    printf("firmware_app_host: %d failures (polarity refused after %d steps)\n", failures, steps_fault);
    return failures != 0;
}
