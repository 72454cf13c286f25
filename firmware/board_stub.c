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
static volatile uint32_t pwm_arr;   /* the timer's auto-reload: half the carrier in clock ticks */
#define TIMER_CLOCK_HZ 168e6f      /* a 168 MHz timer clock, counting up and down */

bool board_pwm_init(float T_pwm)
{
    const float arr = 0.5f * T_pwm * TIMER_CLOCK_HZ;   /* centre-aligned: up and down in one carrier period */
    if (!(arr >= 100.0f && arr <= 65535.0f)) return false;   /* a 16-bit timer, at least 100 ticks of resolution */
    pwm_arr = (uint32_t)(arr + 0.5f);
    return true;
}

void board_read(board_sample *s)
{
    for (int k = 0; k < FS_PHASES_MAX; ++k) s->i_ph[k] = adc_i[k];
    s->u_dc = adc_u_dc;
    s->enc = enc_cnt;
}

void board_set_duty(const float duty[], int phases)
{
    const float arr = (float)pwm_arr;
    for (int k = 0; k < phases; ++k) pwm_ccr[k] = (uint32_t)(duty[k] * arr + 0.5f);
}

void board_pwm(bool on) { pwm_moe = on; }
