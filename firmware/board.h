/* What the integration layer (drive_app.c) needs from a board: replace
 * board_stub.c with these four functions over your HAL.
 *
 * Timing (the simulator's, fs_sim.h): a centre-aligned carrier of period
 * T_pwm; the phase currents, the dc link and the encoder are sampled at the
 * carrier's peak, in the zero vector (all low-side switches on: where
 * low-side shunts see the phase currents), the PWM update interrupt runs on
 * that event, and the compare values it writes are preloaded: they take
 * effect at the next update event, one control period later (config delay
 * = 1). With double sampling (Ts = T_pwm / 2) both the peak and the valley
 * are update events.
 */
#ifndef BOARD_H
#define BOARD_H

#include <stdbool.h>
#include <stdint.h>
#include "fs_types.h"

/* The carrier the configuration was designed for: centre-aligned, period
 * T_pwm (s, fs_drive_config.T_pwm), the update event at its peak (and valley
 * with double sampling); false, and the PWM left off, where the timer cannot
 * make it. The drive's model of when its voltage acts is this period. */
bool board_pwm_init(float T_pwm);

/* The raw conversions of one sampling instant. */
typedef struct {
    uint16_t i_ph[FS_PHASES_MAX];   /* phase-current ADC codes (the first `phases`) */
    uint16_t u_dc;                  /* dc-link voltage ADC code */
    uint32_t enc;                   /* encoder count, 0 .. counts per turn - 1 */
} board_sample;

/* The conversions triggered at the last update event (already complete when
 * the interrupt runs: read the injected-conversion data registers). */
void board_read(board_sample *s);
/* Preload the compare registers: compare = duty x period, duty in [0, 1] the
 * high-side on-time fraction of phase k; effective from the next update event. */
void board_set_duty(const float duty[], int phases);
/* Outputs on (complementary PWM with the hardware dead time), or off: every
 * switch open at once (the break input's action), currents decay through the
 * diodes. */
void board_pwm(bool on);

#endif /* BOARD_H */
