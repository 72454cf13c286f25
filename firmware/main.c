/* A minimal Cortex-M4F image around the drive step, for bench/firmware.py.
 *
 * It exists to be linked, not run: the linker (with --gc-sections) keeps
 * exactly what a real drive keeps -- fs_drive_init for the configuration,
 * fs_drive_step in the PWM interrupt, and the libm float routines they call --
 * so the image's size and symbols answer "what does the control code cost on
 * the target" and "does any double-precision code reach it".
 *
 * The "peripherals" are volatile variables: the compiler must read the ADC
 * and encoder and write the compare registers on every interrupt, as it
 * would with memory-mapped registers, so nothing is constant-folded away.
 */
#include "fs_drive.h"

/* Fake peripheral registers. */
static volatile float adc_i_abc[3];   /* phase currents, A */
static volatile float adc_u_dc = 24.0f;
static volatile float enc_theta_m;    /* mechanical angle, rad */
static volatile float pwm_compare[3]; /* duties */
static volatile int host_sensorless;  /* set by the "application" */

static fs_drive drive;

/* The PWM update interrupt: sample, step, write the duties. */
void PWM_IRQHandler(void)
{
    fs_drive_in in = {0};
    fs_drive_out out;
    for (int k = 0; k < 3; ++k) in.i_ph[k] = adc_i_abc[k];
    in.u_dc = adc_u_dc;
    in.theta_m_enc = enc_theta_m;
    in.w_m_ref = 62.8f;
    in.sensorless = host_sensorless;
    fs_drive_step(&drive, &in, &out);
    for (int k = 0; k < 3; ++k) pwm_compare[k] = out.duty[k];
}

int main(void)
{
    /* yang2022 machine and bench (src/fullspeed/machines/yang2022.toml);
     * fields not set here are 0, which means "off" for any added later. */
    fs_drive_config cfg = {0};
    cfg.phases = 3;
    cfg.mode = FS_MODE_SPEED;
    cfg.angle_source = FS_ANGLE_SMO;
    cfg.Ts = 1.0e-4f;
    cfg.T_pwm = 1.0e-4f;
    cfg.delay = 1.0f;
    cfg.R_s = 0.036f;
    cfg.L_d = 0.065e-3f;
    cfg.L_q = 0.090e-3f;
    cfg.psi_f = 0.007f;
    cfg.pole_pairs = 5;
    cfg.J = 1.87e-3f;
    cfg.B = 2.0e-4f;
    cfg.i_max = 60.0f;
    cfg.T_max = 2.5f;
    cfg.bw_current = 3000.0f;
    cfg.bw_speed = 40.0f;
    cfg.bw_pll = 628.0f;
    cfg.t_dead_comp = 1.0e-6f;
    cfg.i_dead_band = 0.6f;
    cfg.smo.w_e_max = 1570.0f;
    cfg.smo.i_max = 60.0f;
    cfg.smo.margin = 1.5f;
    cfg.smo.w_c_min = 10.5f;
    cfg.smo.bw_pll = 250.0f;
    cfg.smo.w_valid = 52.4f;
    if (fs_drive_init(&drive, &cfg) != FS_OK) {
        for (;;) {
        }
    }
    /* Stands in for the interrupt controller calling the handler. */
    for (;;) {
        PWM_IRQHandler();
    }
}
