/* A stand-in board for the link and size check (bench/firmware.py): the
 * "peripherals" are volatile variables, so the compiler must read the ADC
 * and the encoder and write the compare registers on every interrupt, as it
 * would with memory-mapped registers. Replace this file with your HAL. */
#include "board.h"

static volatile uint16_t adc_i[FS_PHASES_MAX];
static volatile uint16_t adc_u_dc;
static volatile uint32_t enc_cnt;
static volatile uint32_t pwm_ccr[FS_PHASES_MAX];
static volatile uint32_t pwm_moe;
#define PWM_PERIOD 4200u   /* 168 MHz / (2 x 20 kHz), centre-aligned: a 20 kHz carrier */

void board_read(board_sample *s)
{
    for (int k = 0; k < FS_PHASES_MAX; ++k) s->i_ph[k] = adc_i[k];
    s->u_dc = adc_u_dc;
    s->enc = enc_cnt;
}

void board_set_duty(const float duty[], int phases)
{
    for (int k = 0; k < phases; ++k) pwm_ccr[k] = (uint32_t)(duty[k] * (float)PWM_PERIOD + 0.5f);
}

void board_pwm(bool on) { pwm_moe = on; }
