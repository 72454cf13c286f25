#include "fs_sim.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fs_profile.h"

enum { P_W_M_REF, P_I_D_REF, P_I_Q_REF, P_U_D_REF, P_U_Q_REF, P_W_E_REF, P_T_LOAD, P_W_LOAD, P_SENSORLESS, P_N };

struct fs_sim {
    fs_sim_config cfg;
    fs_pmsm pmsm;
    fs_drive drive;
    fs_pwl prof[P_N];
    double x[FS_X_N];
    double Tc;               /* control period */
    long long k;             /* samples taken */
    int phases;              /* 3 or 5 */
    int nx;                  /* states integrated: FS_X_N3 (three phases) or FS_X_N */
    double duty_next[FS_INV_MAX_LEGS];   /* computed, waiting for the update instant */
    double duty_now[FS_INV_MAX_LEGS];    /* acting in the current period */
    uint64_t rng;
    int stopped;             /* fs_run_status of a stop, or 0 */
    double stop_time;
};

/* The runner passes drive duties to the inverter and phase currents back. */
typedef char fs_sim_legs_check[((int)FS_INV_MAX_LEGS >= (int)FS_PHASES_MAX) ? 1 : -1];

static double pi_const(void) { return 3.14159265358979323846; }

static double wrap_pi(double x)
{
    const double PI = pi_const();
    if (x > -PI && x <= PI) return x;
    x = fmod(x + PI, 2.0 * PI);
    if (x <= 0.0) x += 2.0 * PI;
    return x - PI;
}

/* xorshift64* and Box-Muller: reproducible noise from the seed. */
static double rng_uniform(uint64_t *s)
{
    uint64_t x = *s;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    *s = x;
    return ((x * 2685821657736338717ULL) >> 11) * (1.0 / 9007199254740992.0);
}

static double rng_gauss(uint64_t *s)
{
    double u1 = rng_uniform(s), u2 = rng_uniform(s);
    if (u1 < 1e-300) u1 = 1e-300;
    return sqrt(-2.0 * log(u1)) * cos(2.0 * pi_const() * u2);
}

static double adc(fs_sim *s, double i)
{
    const fs_sim_config *c = &s->cfg;
    if (c->noise_i > 0.0) i += c->noise_i * rng_gauss(&s->rng);
    if (c->adc_bits > 0) {
        double lsb = 2.0 * c->adc_range / ldexp(1.0, c->adc_bits);
        if (i > c->adc_range) i = c->adc_range;
        if (i < -c->adc_range) i = -c->adc_range;
        i = lsb * nearbyint(i / lsb);
    }
    return i;
}

static double encoder(const fs_sim *s, double theta_m)
{
    double th = wrap_pi(theta_m);
    if (s->cfg.encoder_bits > 0) {
        double lsb = 2.0 * pi_const() / ldexp(1.0, s->cfg.encoder_bits);
        th = lsb * nearbyint(th / lsb);  /* bin centre: no bias */
    }
    return th;
}

/* Phase currents (s->phases of them) of a state, and the rotor-frame ones. */
static void phase_currents(fs_sim *s, const double *x, double *i_ph, double *i_d, double *i_q)
{
    double id, iq;
    fs_mag_current(&s->pmsm.mag, x[FS_X_PSI_D], x[FS_X_PSI_Q], &id, &iq);
    double th = s->pmsm.cfg.pole_pairs * x[FS_X_THETA_M];
    double cs = cos(th), sn = sin(th);
    double ia = cs * id - sn * iq, ib = sn * id + cs * iq;
    if (s->phases == 5) {
        double id3, iq3;
        fs_pmsm_currents3(&s->pmsm, x, &id3, &iq3);
        double c3 = cos(3.0 * th), s3 = sin(3.0 * th);
        fs_inverter_vsd5_inverse(ia, ib, c3 * id3 - s3 * iq3, s3 * id3 + c3 * iq3, 0.0, i_ph);
    } else {
        i_ph[0] = ia;
        i_ph[1] = -0.5 * ia + 0.5 * sqrt(3.0) * ib;
        i_ph[2] = -0.5 * ia - 0.5 * sqrt(3.0) * ib;
    }
    if (i_d) *i_d = id;
    if (i_q) *i_q = iq;
}

#define FAIL(...) do { snprintf(err, (size_t)err_len, __VA_ARGS__); fs_sim_destroy(s); return NULL; } while (0)

fs_sim *fs_sim_create(const fs_sim_config *cfg, char *err, int err_len)
{
    fs_sim *s = calloc(1, sizeof(*s));
    if (!s) { snprintf(err, (size_t)err_len, "out of memory"); return NULL; }
    s->cfg = *cfg;
    const fs_profile *src[P_N] = {&cfg->w_m_ref, &cfg->i_d_ref, &cfg->i_q_ref, &cfg->u_d_ref,
                                  &cfg->u_q_ref, &cfg->w_e_ref, &cfg->T_load, &cfg->w_load,
                                  &cfg->sensorless};
    static const char *names[P_N] = {"w_m_ref", "i_d_ref", "i_q_ref", "u_d_ref",
                                     "u_q_ref", "w_e_ref", "T_load", "w_load", "sensorless"};
    for (int p = 0; p < P_N; ++p) {
        if (fs_pwl_copy(&s->prof[p], src[p]) != 0)
            FAIL("profile %s: times must be non-decreasing", names[p]);
    }
    if (!(cfg->inverter.T_pwm > 0.0)) FAIL("inverter.T_pwm = %g: must be > 0", cfg->inverter.T_pwm);
    if (!(cfg->inverter.t_dead >= 0.0) || cfg->inverter.t_dead >= 0.5 * cfg->inverter.T_pwm)
        FAIL("inverter.t_dead = %g: must be in [0, T_pwm/2)", cfg->inverter.t_dead);
    if (!(cfg->inverter.u_dc > 0.0)) FAIL("inverter.u_dc = %g: must be > 0", cfg->inverter.u_dc);
    if (cfg->sampling != FS_SAMPLING_SINGLE && cfg->sampling != FS_SAMPLING_DOUBLE)
        FAIL("timing.sampling = %d: must be single (0) or double (1)", cfg->sampling);
    if (!(cfg->h_max > 0.0)) FAIL("timing.h_max = %g: must be > 0", cfg->h_max);
    if (cfg->decimation < 1) FAIL("trace.decimation = %d: must be >= 1", cfg->decimation);
    const int ph = cfg->plant.phases;
    if (ph != 3 && ph != 5) FAIL("plant.phases = %d: must be 3 or 5", ph);
    if (cfg->inverter.phases != ph)
        FAIL("inverter.phases = %d: must equal plant.phases (%d)", cfg->inverter.phases, ph);
    if (cfg->drive.phases != ph)
        FAIL("controller.phases = %d: must equal plant.phases (%d)", cfg->drive.phases, ph);
    if (ph == 5) {
        if (!(cfg->plant.L_d3 > 0.0 && isfinite(cfg->plant.L_d3)))
            FAIL("plant.L_d3 = %g: must be > 0 for a five-phase machine", cfg->plant.L_d3);
        if (!(cfg->plant.L_q3 > 0.0 && isfinite(cfg->plant.L_q3)))
            FAIL("plant.L_q3 = %g: must be > 0 for a five-phase machine", cfg->plant.L_q3);
        if (!(cfg->plant.psi_f3 >= 0.0 && isfinite(cfg->plant.psi_f3)))
            FAIL("plant.psi_f3 = %g: must be >= 0 for a five-phase machine", cfg->plant.psi_f3);
    }
    s->phases = ph;
    s->nx = ph == 5 ? FS_X_N : FS_X_N3;
    if (fs_pmsm_init(&s->pmsm, &cfg->plant) != 0) FAIL("machine: invalid plant parameters");
    s->Tc = cfg->sampling == FS_SAMPLING_DOUBLE ? 0.5 * cfg->inverter.T_pwm : cfg->inverter.T_pwm;
    if (fabs(cfg->drive.Ts - s->Tc) > 1e-6 * s->Tc)
        FAIL("controller.Ts = %g: must equal the control period %g", cfg->drive.Ts, s->Tc);
    fs_status st = fs_drive_init(&s->drive, &cfg->drive);
    if (st != FS_OK) FAIL("controller: %s", fs_status_str(st));

    fs_pmsm_initial_state(&s->pmsm, s->x);
    s->x[FS_X_THETA_M] = cfg->theta_m0;
    s->x[FS_X_W_M] = cfg->w_m0;
    if (cfg->plant.load_kind == FS_LOAD_SPEED_IDEAL)
        s->x[FS_X_W_M] = fs_pwl_eval(&s->prof[P_W_LOAD], 0.0, NULL);
    for (int k = 0; k < FS_INV_MAX_LEGS; ++k) s->duty_now[k] = s->duty_next[k] = 0.5;
    s->rng = cfg->seed ? cfg->seed : 0x9E3779B97F4A7C15ULL;
    s->stop_time = NAN;
    return s;
}

void fs_sim_destroy(fs_sim *s)
{
    if (!s) return;
    for (int p = 0; p < P_N; ++p) fs_pwl_free(&s->prof[p]);
    free(s);
}

double fs_sim_time(const fs_sim *s) { return (double)s->k * s->Tc; }
double fs_sim_stop_time(const fs_sim *s) { return s->stop_time; }

/* Integrate the plant over one control period with the duties now acting. */
static void integrate_period(fs_sim *s, double t0)
{
    const fs_inverter_config *inv = &s->cfg.inverter;
    fs_pmsm_input in;
    double slope;
    in.T_load = fs_pwl_eval(&s->prof[P_T_LOAD], t0, NULL);
    in.w_load = fs_pwl_eval(&s->prof[P_W_LOAD], t0, &slope);
    in.dw_load = slope;
    double i_ph[FS_INV_MAX_LEGS];
    int halves = s->cfg.sampling == FS_SAMPLING_DOUBLE ? 1 : 2;
    int half0 = s->cfg.sampling == FS_SAMPLING_DOUBLE ? (int)(s->k & 1) : 0;
    for (int h = 0; h < halves; ++h) {
        int half = half0 + h;
        if (inv->kind == FS_INV_SWITCHING) {
            fs_inv_segments seg;
            fs_inverter_segments(inv, s->duty_now, half, &seg);
            for (int n = 0; n < seg.n; ++n) {
                phase_currents(s, s->x, i_ph, NULL, NULL);
                fs_inverter_voltage(inv, seg.state[n], i_ph, &in.u_alpha, &in.u_beta, &in.u_x, &in.u_y);
                int steps = (int)ceil(seg.dt[n] / s->cfg.h_max - 1e-9);
                double hstep = seg.dt[n] / steps;
                for (int m = 0; m < steps; ++m) fs_pmsm_rk4(&s->pmsm, s->x, &in, hstep);
            }
        } else {
            double Th = 0.5 * inv->T_pwm;
            int steps = (int)ceil(Th / s->cfg.h_max - 1e-9);
            double hstep = Th / steps;
            /* the mean voltage depends on the currents only through dead time
             * and drops: without them it is one value for the half period */
            int ideal = inv->t_dead == 0.0 && inv->u_on == 0.0;
            if (ideal) {
                for (int k = 0; k < FS_INV_MAX_LEGS; ++k) i_ph[k] = 0.0;
                fs_inverter_mean_voltage(inv, s->duty_now, i_ph, &in.u_alpha, &in.u_beta, &in.u_x, &in.u_y);
            }
            for (int m = 0; m < steps; ++m) {
                if (!ideal) {
                    phase_currents(s, s->x, i_ph, NULL, NULL);
                    fs_inverter_mean_voltage(inv, s->duty_now, i_ph, &in.u_alpha, &in.u_beta, &in.u_x,
                                             &in.u_y);
                }
                fs_pmsm_rk4(&s->pmsm, s->x, &in, hstep);
            }
        }
    }
}

int fs_sim_run(fs_sim *s, double t_end, double *trace, int max_rows, int *rows)
{
    *rows = 0;
    if (s->stopped) return s->stopped;
    const fs_sim_config *c = &s->cfg;
    const int p = c->plant.pole_pairs;
    while ((double)s->k * s->Tc < t_end - 0.5 * s->Tc) {
        int record = (s->k % c->decimation) == 0;
        if (record && *rows >= max_rows) return FS_RUN_BUFFER_FULL;
        double t = (double)s->k * s->Tc;
        double slope;
        if (c->plant.load_kind == FS_LOAD_SPEED_IDEAL)
            s->x[FS_X_W_M] = fs_pwl_eval(&s->prof[P_W_LOAD], t, &slope);

        /* sample */
        double i_ph[FS_INV_MAX_LEGS], i_d, i_q;
        phase_currents(s, s->x, i_ph, &i_d, &i_q);
        fs_drive_in din;
        for (int k = 0; k < s->phases; ++k) din.i_ph[k] = (float)adc(s, i_ph[k]);
        for (int k = s->phases; k < FS_PHASES_MAX; ++k) din.i_ph[k] = 0.0f;
        din.u_dc = (float)c->inverter.u_dc;
        din.theta_m_enc = (float)encoder(s, s->x[FS_X_THETA_M]);
        din.theta_e_ext = (float)wrap_pi(p * s->x[FS_X_THETA_M]);
        din.w_e_ext = (float)(p * s->x[FS_X_W_M]);
        din.w_m_ref = (float)fs_pwl_eval(&s->prof[P_W_M_REF], t, NULL);
        din.i_d_ref = (float)fs_pwl_eval(&s->prof[P_I_D_REF], t, NULL);
        din.i_q_ref = (float)fs_pwl_eval(&s->prof[P_I_Q_REF], t, NULL);
        din.u_d_ref = (float)fs_pwl_eval(&s->prof[P_U_D_REF], t, NULL);
        din.u_q_ref = (float)fs_pwl_eval(&s->prof[P_U_Q_REF], t, NULL);
        din.w_e_ref = (float)fs_pwl_eval(&s->prof[P_W_E_REF], t, NULL);
        din.sensorless = fs_pwl_eval(&s->prof[P_SENSORLESS], t, NULL) > 0.5;

        /* control */
        fs_drive_out dout;
        fs_drive_step(&s->drive, &din, &dout);
        for (int k = 0; k < s->phases; ++k) s->duty_next[k] = dout.duty[k];
        if (!c->delay) for (int k = 0; k < s->phases; ++k) s->duty_now[k] = s->duty_next[k];

        if (record) {
            double *r = trace + (size_t)(*rows) * FS_CH_N;
            fs_pmsm_input pin = {0};
            pin.T_load = fs_pwl_eval(&s->prof[P_T_LOAD], t, NULL);
            pin.w_load = fs_pwl_eval(&s->prof[P_W_LOAD], t, NULL);
            double Te, Tl, id2, iq2;
            fs_pmsm_outputs(&s->pmsm, s->x, &pin, &id2, &iq2, &Te, &Tl);
            double theta_e = wrap_pi(p * s->x[FS_X_THETA_M]);
            r[FS_CH_T] = t;
            r[FS_CH_THETA_E] = theta_e;
            r[FS_CH_W_M] = s->x[FS_X_W_M];
            r[FS_CH_PSI_D] = s->x[FS_X_PSI_D];
            r[FS_CH_PSI_Q] = s->x[FS_X_PSI_Q];
            r[FS_CH_I_D] = i_d;
            r[FS_CH_I_Q] = i_q;
            r[FS_CH_I_A] = i_ph[0];
            r[FS_CH_I_B] = i_ph[1];
            r[FS_CH_I_C] = i_ph[2];
            r[FS_CH_T_E] = Te;
            r[FS_CH_T_L] = Tl;
            r[FS_CH_U_D] = s->k > 0 ? s->x[FS_X_UD_INT] / s->Tc : 0.0;
            r[FS_CH_U_Q] = s->k > 0 ? s->x[FS_X_UQ_INT] / s->Tc : 0.0;
            r[FS_CH_DUTY_A] = dout.duty[0];
            r[FS_CH_DUTY_B] = dout.duty[1];
            r[FS_CH_DUTY_C] = dout.duty[2];
            r[FS_CH_W_M_REF] = din.w_m_ref;
            r[FS_CH_I_D_REF] = dout.i_d_ref;
            r[FS_CH_I_Q_REF] = dout.i_q_ref;
            r[FS_CH_T_REF] = dout.T_ref;
            r[FS_CH_I_D_HAT] = dout.i_d;
            r[FS_CH_I_Q_HAT] = dout.i_q;
            r[FS_CH_U_D_REF] = dout.u_d;
            r[FS_CH_U_Q_REF] = dout.u_q;
            r[FS_CH_THETA_HAT] = dout.theta_e;
            r[FS_CH_W_M_HAT] = dout.w_e / p;
            r[FS_CH_THETA_ERR] = wrap_pi(theta_e - dout.theta_e);
            r[FS_CH_OVERMOD] = dout.over_modulation;
            r[FS_CH_E_IN] = s->x[FS_X_E_IN];
            r[FS_CH_E_CU] = s->x[FS_X_E_CU];
            r[FS_CH_E_AIRGAP] = s->x[FS_X_E_AIRGAP];
            r[FS_CH_W_MAG] = fs_pmsm_energy(&s->pmsm, s->x);
            r[FS_CH_THETA_EST] = dout.theta_est;
            r[FS_CH_W_M_EST] = dout.w_est / p;
            r[FS_CH_EST_VALID] = dout.est_valid;
            r[FS_CH_EST_ERR] = wrap_pi(theta_e - dout.theta_est);
            r[FS_CH_PHASE] = dout.phase;
            r[FS_CH_I_D_FW] = dout.i_d_fw;
            r[FS_CH_G_W] = dout.g_w;
            r[FS_CH_INJECT] = dout.injecting;
            fs_pmsm_currents3(&s->pmsm, s->x, &r[FS_CH_I_D3], &r[FS_CH_I_Q3]);
            r[FS_CH_I_HF_D] = dout.i_hf_d;
            r[FS_CH_I_HF_Q] = dout.i_hf_q;
            ++*rows;
        }

        /* the plant over this period */
        s->x[FS_X_UD_INT] = s->x[FS_X_UQ_INT] = 0.0;
        integrate_period(s, t);
        if (c->delay) for (int k = 0; k < s->phases; ++k) s->duty_now[k] = s->duty_next[k];
        ++s->k;
        s->x[FS_X_THETA_M] = fmod(s->x[FS_X_THETA_M], 2.0 * pi_const());

        for (int n = 0; n < s->nx; ++n) {
            if (!isfinite(s->x[n])) {
                s->stopped = FS_STOP_NAN;
                s->stop_time = fs_sim_time(s);
                return s->stopped;
            }
        }
        if (c->i_trip > 0.0) {
            phase_currents(s, s->x, i_ph, NULL, NULL);
            for (int k = 0; k < s->phases; ++k) {
                if (fabs(i_ph[k]) > c->i_trip) {
                    s->stopped = FS_STOP_OVERCURRENT;
                    s->stop_time = fs_sim_time(s);
                    return s->stopped;
                }
            }
        }
    }
    return FS_RUN_DONE;
}
