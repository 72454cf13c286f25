/* A Cortex-M4F image of the drive, for bench/firmware.py: its size, its
 * symbols (no double precision), and the shape of a real firmware.
 *
 * The configuration is fs_config.c, written by
 *     fullspeed export beyond-full-range --out firmware --name fs_config
 * (the yang2022 machine sensorless from standstill: polarity detection,
 * injection, the blend, the back-EMF observer and flux weakening), the one
 * the simulation of that scenario used, byte for byte (tests/test_export.py
 * keeps it equal to a fresh export). The board is board_stub.c; a real
 * firmware replaces it, and the loop below, with its HAL and its scheduler.
 */
#include "drive_app.h"
#include "fs_config.h"

static drive_app app;

/* The PWM update interrupt (the vector table names it). */
void PWM_IRQHandler(void) { app_pwm_isr(&app); }

int main(void)
{
    const app_config board = {
        .i_gain = 0.048828125f,    /* 200 A over 4096 codes: a 12-bit ADC at +-100 A, the bench's adc_range */
        .u_gain = 0.0146484375f,   /* 60 V over 4096 codes */
        .enc_counts = 4096.0f,
        .enc_offset = 0.0f,
        .i_trip = 75.0f,           /* the yang2022 bench's i_trip, 25 % above i_max */
        .u_dc_min = 18.0f, .u_dc_max = 30.0f,
        .ramp = 192.0f,            /* rad/s per s: 0 -> 4400 rpm in 2.4 s, the scenario's ramp */
    };
    if (app_init(&app, &fs_config, &board) != 0) {
        for (;;) {   /* app.drive.fail names the refused field; APP_ERR_PWM: the timer cannot make T_pwm */
        }
    }
    app_calibrate(&app, 64);
    app.sensorless = 1;
    app_start(&app);
    app.w_m_ref = 460.8f;          /* 4400 rpm, reached along the ramp */
    for (;;) {   /* stands in for the interrupt controller calling the handler */
        PWM_IRQHandler();
    }
}
