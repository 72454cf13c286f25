#include "fs_sim.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fs_profile.h"

enum { P_W_M_REF, P_I_D_REF, P_I_Q_REF, P_U_D_REF, P_U_Q_REF, P_W_E_REF, P_T_LOAD, P_W_LOAD, P_SENSORLESS,
       P_U_DC_SCALE, P_N };
/* fs_sim_hold's indices are these */
typedef char fs_sim_profile_check[((int)P_W_M_REF == (int)FS_SIM_W_M_REF && (int)P_T_LOAD == (int)FS_SIM_T_LOAD
                                   && (int)P_W_LOAD == (int)FS_SIM_W_LOAD && (int)P_U_DC_SCALE == (int)FS_SIM_U_DC_SCALE
                                   && (int)P_N == (int)FS_SIM_PROFILES) ? 1 : -1];

/* The trace's channel groups a configuration can hold constant (row_group). */
enum { G_IMC, G_THERMAL, G_METERS, G_LOSSES, G_FIVE, G_ADAPT, G_N, G_MAX = 6 };

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
    int imc;                 /* the converter is a matrix converter */
    double g[FS_GRID_X_N];   /* its input side */
    double g_int[3];         /* over the period: int i_grid_a, int v_pn, int u_AB */
    fs_imc_rect rect_next, rect_now;
    double duty_next[FS_INV_MAX_LEGS];   /* computed, waiting for the update instant */
    double duty_now[FS_INV_MAX_LEGS];    /* acting in the current period */
    uint64_t rng;
    int stopped;             /* fs_run_status of a stop, or 0 */
    double stop_time;
    double u_dc0;            /* the dc link's nominal voltage (cfg.inverter.u_dc follows the fault profile) */
    float theta_enc_held;    /* the encoder's reading once it has stopped */
    int sensor_fault;        /* cfg.fault has a sensor offset or gain error */
    double adc_sat_time;     /* first saturated current reading, or NaN */
    /* no sensor fault, noise or quantisation: adc is adc_clip (the wall bench's
     * example: its loop 3804 -> 3766 instructions a sample, callgrind) */
    int adc_clip_only;
    int thermal_on;          /* cfg.thermal.enabled */
    fs_thermal thermal;
    double e_cu_prev;        /* the copper-loss meter at the start of the period, J */
    double k_mag;            /* the magnet factor the plant has */
    double psi_f_true;       /* the plant's open-circuit magnet flux, Wb */
    int held[P_N];           /* fs_sim_hold: the master's value in place of the profile */
    /* A profile whose value and slope are the same at every time: held
     * (fs_sim_hold), or of one point or none (a constant reference, most of
     * a scenario's), whose value fs_pwl_eval gives as y[0] (0 for none) and
     * slope 0 at every time: read from here, without the piece's tests */
    int fixed[P_N];
    double fixed_y[P_N], fixed_slope[P_N];
    int sampled;             /* fs_sim_sample ran and fs_sim_actuate has not */
    double e_in0, p_cond0;   /* at the last sample: the input energy meter, J, and the devices' conduction loss, W */
    double theta_e;          /* at the last sample: the true electrical angle, wrapped (its trace row's) */
    /* The phase and rotor-frame currents of the state as it is, computed by
     * the overcurrent check at the end of a period and taken by the next
     * sample instead of computing them again (the same function of the same
     * state: the same bits). Not with a flux map, whose current solve starts
     * from its last solution (fs_mag_current's hint): a second solve of the
     * same state can differ in the last bit, so it is solved twice as before. */
    int cur_ok;
    double cur_ph[FS_INV_MAX_LEGS];
    fs_pmsm_at cur_at;       /* the angle's cosine and sine, the rotor-frame currents */
    double e_dc0;            /* at the last sample: the source's meter (with the loss meters), J */
    int losses;              /* cfg.plant.losses: the loss meters run */
    int imc_real;            /* the matrix converter with devices, dead time or meters (imc_deriv_real) */
    double e_dc, e_cond, e_rect, e_sw;   /* the converter's meters (fs_sim.h), J */
    int leg_state[FS_INV_MAX_LEGS];      /* switching inverter, with meters: the legs' states in the last segment */
    int inv_ideal;           /* no dead time, drops or devices: the mean voltage does not depend on the currents */
    int held_group[G_N];     /* the trace's channel groups the configuration holds constant (G_*, row_group) */
    int half_steps;          /* averaged inverter: RK4 steps a half period, */
    double half_h;           /* each this long (substeps of T_pwm / 2) */
    int avg_ideal;           /* the averaged inverter, inv_ideal, no loss meters: integrate_period_ideal */
};

/* The runner passes drive duties to the inverter and phase currents back. */
typedef char fs_sim_legs_check[((int)FS_INV_MAX_LEGS >= (int)FS_PHASES_MAX) ? 1 : -1];

/* Inlined at every call: the row writers specialised by their constant
 * arguments (below), and the runner loop's own parts (sample, the ideal
 * averaged period), which it calls once a sample. */
#if defined(__GNUC__)
#define FS_SPECIALISE static inline __attribute__((always_inline))
#else
#define FS_SPECIALISE static inline
#endif

/* Profile p at t, and its slope: the master's held value where it holds one (fs_sim_hold), a flat
 * profile's one value (fixed). */
static double prof(fs_sim *s, int p, double t, double *slope)
{
    if (s->fixed[p] != 0) {
        if (slope) *slope = s->fixed_slope[p];
        return s->fixed_y[p];
    }
    return fs_pwl_eval(&s->prof[p], t, slope);
}

static double pi_const(void) { return 3.14159265358979323846; }

/* fmod(x, y) for y > 0 and |x| >= 2 y, bit for bit (fmod is exact, so any
 * exact way to its value gives its bits): |x| less y 2^j where that fits,
 * for j from the largest with y 2^j <= |x| down to 0, each difference exact
 * (Sterbenz: m <= a < 2 m), with x's sign, a zero's too, as the controller's
 * fs_fmod_2pi does. For |x| < 2^16 y (the electrical angle of a wrapped
 * rotor angle is below 2 p pi); NaN, infinities and beyond take fmod. */
#if defined(__GNUC__)
__attribute__((noinline))   /* the rare path, kept out of wrap_pi so that wrap_pi stays inlined */
#endif
static double fmod_far(double x, double y)
{
    double a = fabs(x);
    if (!(a < 65536.0 * y)) return fmod(x, y);
    double m = y;
    int n = 0;
    while (a >= 2.0 * m) {
        m *= 2.0;
        ++n;
    }
    for (int j = 0; j <= n; ++j) {   /* a < 2 m throughout */
        if (a >= m) a -= m;
        m *= 0.5;
    }
    return copysign(a, x);
}

/* fmod(x, y) for 2 y <= x < 4 y, bit for bit: x - 2 y is exact (Sterbenz
 * with 2 y: y <= x <= 4 y), and less y once more where it is y or more
 * (exact again), the remainder fmod gives, +0 for a multiple of y; its
 * caller negates it for a negative x (fmod's -0 then). wrap_pi's p theta_m
 * + pi, theta_m wrapped to [0, 2 pi), falls here for p = 3 (the wall bench's
 * machine) in half the samples: in place of fmod_far's call and its loops. */
static double fmod_twice(double x, double y)
{
    const double a = x - 2.0 * y;
    return a < y ? a : a - y;
}

/* fmod(x, y) for y > 0, bit for bit, without the library call where |x| <
 * 2 y (an angle wrapped once a sample never leaves that band): fmod is exact
 * (x - n y for n = trunc(x / y)), so it is x itself for |x| < y, and for y
 * <= |x| < 2 y it is x -+ y, which the subtraction gives exactly (Sterbenz:
 * y / 2 <= |x| <= 2 y), with fmod's sign (x's) where that is zero; below
 * 4 y fmod_twice. The rest take fmod_far. */
static double fmod_near(double x, double y)
{
    if (x >= 0.0) {
        if (x < y) return x;
        if (x < 2.0 * y) return x - y;
        if (x < 4.0 * y) return fmod_twice(x, y);
    } else if (x > -2.0 * y) {
        if (x > -y) return x;
        return x == -y ? -0.0 : x + y;   /* fmod keeps x's sign: -y gives -0 */
    } else if (x > -4.0 * y) {
        return -fmod_twice(-x, y);
    }
    return fmod_far(x, y);
}

static double wrap_pi(double x)
{
    const double PI = pi_const();
    if (x > -PI && x <= PI) return x;
    x = fmod_near(x + PI, 2.0 * PI);
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

/* A current clipped to the ADC's range (if it has one) at time t. */
static double adc_clip(fs_sim *s, double i, double t)
{
    const fs_sim_config *c = &s->cfg;
    if (c->adc_range > 0.0 && fabs(i) > c->adc_range) {
        i = copysign(c->adc_range, i);
        if (isnan(s->adc_sat_time)) s->adc_sat_time = t;
    }
    return i;
}

/* Phase k's current as its sensor and the ADC read it at time t. */
static double adc(fs_sim *s, int k, double i, double t)
{
    const fs_sim_config *c = &s->cfg;
    if (s->sensor_fault && t >= c->fault.t_sensor) i = (1.0 + c->fault.i_gain[k]) * i + c->fault.i_offset[k];
    if (c->noise_i > 0.0) i += c->noise_i * rng_gauss(&s->rng);
    i = adc_clip(s, i, t);
    if (c->adc_bits > 0) {
        double lsb = 2.0 * c->adc_range / ldexp(1.0, c->adc_bits);
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

/* Three phase quantities of a stationary-frame vector (amplitude-invariant). */
static void inv_clarke3(double a, double b, double *v)
{
    v[0] = a;
    v[1] = -0.5 * a + 0.5 * sqrt(3.0) * b;
    v[2] = -0.5 * a - 0.5 * sqrt(3.0) * b;
}

/* The fundamental-plane current of a state: stationary (alpha, beta), with
 * the angle's cosine and sine and the rotor frame's (d, q) in a. */
static void stator_current_at(fs_sim *s, const double *x, double *i_a, double *i_b, fs_pmsm_at *a)
{
    fs_pmsm_at_state(&s->pmsm, x, a);
    *i_a = a->cs * a->i_d - a->sn * a->i_q;
    *i_b = a->sn * a->i_d + a->cs * a->i_q;
}

/* The same, the rotor frame's only if asked. */
static void stator_current(fs_sim *s, const double *x, double *i_a, double *i_b, double *i_d, double *i_q)
{
    fs_pmsm_at a;
    stator_current_at(s, x, i_a, i_b, &a);
    if (i_d) *i_d = a.i_d;
    if (i_q) *i_q = a.i_q;
}

/* Phase currents (s->phases of them) of a state, and in a what
 * stator_current_at gives. */
static void phase_currents_at(fs_sim *s, const double *x, double *i_ph, fs_pmsm_at *a)
{
    double ia, ib;
    stator_current_at(s, x, &ia, &ib, a);
    if (s->phases == 5) {
        const double th = s->pmsm.cfg.pole_pairs * x[FS_X_THETA_M];
        double id3, iq3;
        fs_pmsm_currents3(&s->pmsm, x, &id3, &iq3);
        double c3 = cos(3.0 * th), s3 = sin(3.0 * th);
        fs_inverter_vsd5_inverse(ia, ib, c3 * id3 - s3 * iq3, s3 * id3 + c3 * iq3, 0.0, i_ph);
    } else {
        inv_clarke3(ia, ib, i_ph);
    }
}

/* Phase currents of a state, and the rotor-frame ones if asked. */
static void phase_currents(fs_sim *s, const double *x, double *i_ph, double *i_d, double *i_q)
{
    fs_pmsm_at a;
    phase_currents_at(s, x, i_ph, &a);
    if (i_d) *i_d = a.i_d;
    if (i_q) *i_q = a.i_q;
}

static void thermal_apply(fs_sim *s);
static int substeps(double T, double h_max);

#define FAIL(...) do { snprintf(err, (size_t)err_len, __VA_ARGS__); fs_sim_destroy(s); return NULL; } while (0)

fs_sim *fs_sim_create(const fs_sim_config *cfg, char *err, int err_len)
{
    if (!err || err_len < 1) err_len = 0;   /* no message buffer: snprintf writes nothing */
    if (!cfg) { if (err_len) snprintf(err, (size_t)err_len, "config is NULL"); return NULL; }
    fs_sim *s = calloc(1, sizeof(*s));
    if (!s) { snprintf(err, (size_t)err_len, "out of memory"); return NULL; }
    s->cfg = *cfg;
    const fs_profile *src[P_N] = {&cfg->w_m_ref, &cfg->i_d_ref, &cfg->i_q_ref, &cfg->u_d_ref,
                                  &cfg->u_q_ref, &cfg->w_e_ref, &cfg->T_load, &cfg->w_load,
                                  &cfg->sensorless, &cfg->u_dc_scale};
    static const char *names[P_N] = {"w_m_ref", "i_d_ref", "i_q_ref", "u_d_ref",
                                     "u_q_ref", "w_e_ref", "T_load", "w_load", "sensorless", "u_dc_scale"};
    for (int p = 0; p < P_N; ++p) {
        if (fs_pwl_copy(&s->prof[p], src[p]) != 0)
            FAIL("profile %s: times must be non-decreasing", names[p]);
        s->fixed[p] = (s->prof[p].n <= 1);
        s->fixed_y[p] = (s->prof[p].n == 1) ? s->prof[p].y[0] : 0.0;
    }
    if (!(cfg->inverter.T_pwm > 0.0) || !isfinite(cfg->inverter.T_pwm))
        FAIL("inverter.T_pwm = %g: must be finite and > 0", cfg->inverter.T_pwm);
    if (!(cfg->inverter.t_dead >= 0.0) || cfg->inverter.t_dead >= 0.5 * cfg->inverter.T_pwm)
        FAIL("inverter.t_dead = %g: must be in [0, T_pwm/2)", cfg->inverter.t_dead);
    if (!(cfg->inverter.r_on >= 0.0) || !isfinite(cfg->inverter.r_on))
        FAIL("converter.r_on = %g: must be finite and >= 0", cfg->inverter.r_on);
    if (!(cfg->inverter.u_dc > 0.0) || !isfinite(cfg->inverter.u_dc))
        FAIL("inverter.u_dc = %g: must be finite and > 0", cfg->inverter.u_dc);
    if (cfg->sampling != FS_SAMPLING_SINGLE && cfg->sampling != FS_SAMPLING_DOUBLE)
        FAIL("timing.sampling = %d: must be single (0) or double (1)", cfg->sampling);
    /* an interval is at most T_pwm: its RK4 step count must fit an int */
    if (!(cfg->h_max > 0.0) || !(cfg->inverter.T_pwm <= 1e6 * cfg->h_max))
        FAIL("timing.h_max = %g: must be > 0 and at least T_pwm / 1e6 = %g", cfg->h_max, 1e-6 * cfg->inverter.T_pwm);
    if (cfg->decimation < 1) FAIL("trace.decimation = %d: must be >= 1", cfg->decimation);
    if (cfg->adc_bits > 0 && !(cfg->adc_range > 0.0)) FAIL("sensors.adc_range = %g: must be > 0 with adc_bits", cfg->adc_range);
    const fs_fault_config *fc = &cfg->fault;
    if (fc->open_phase < 0 || fc->open_phase > 3) FAIL("faults.open_phase = %d: must be 0 (none) or 1..3", fc->open_phase);
    if (fc->open_phase && (cfg->plant.phases != 3 || cfg->converter != FS_CONV_VSI))
        FAIL("faults.open_phase = %d: modelled on a three-phase machine fed by the inverter", fc->open_phase);
    for (int k = 0; k < FS_INV_MAX_LEGS; ++k) {
        if (!isfinite(fc->i_offset[k]) || !(fc->i_gain[k] > -1.0) || !isfinite(fc->i_gain[k]))
            FAIL("faults: phase %d's sensor offset %g A or gain error %g: must be finite, the gain error > -1",
                 k + 1, fc->i_offset[k], fc->i_gain[k]);
    }
    const int ph = cfg->plant.phases;
    if (ph != 3 && ph != 5) FAIL("plant.phases = %d: must be 3 or 5", ph);
    if (cfg->inverter.phases != ph)
        FAIL("inverter.phases = %d: must equal plant.phases (%d)", cfg->inverter.phases, ph);
    fs_status ist = fs_inverter_check(&cfg->inverter);   /* what the messages above leave: kind, u_on, the devices */
    if (ist != FS_OK)
        FAIL("inverter: kind = %d, u_on = %g, devices %s: %s (a device's drops, energies and exponents >= 0, "
             "I_ref, V_ref > 0; u_on, r_on 0 with them)", cfg->inverter.kind, cfg->inverter.u_on,
             cfg->inverter.dev.enabled ? "on" : "off", fs_status_str(ist));
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
    if (cfg->converter != FS_CONV_VSI && cfg->converter != FS_CONV_IMC)
        FAIL("converter.kind = %d: must be the inverter (0) or the matrix converter (1)", cfg->converter);
    if (cfg->drive.converter != cfg->converter)
        FAIL("controller.converter = %d: must equal converter.kind (%d)", cfg->drive.converter, cfg->converter);
    s->imc = cfg->converter == FS_CONV_IMC;
    if (s->imc) {
        if (ph != 3) FAIL("plant.phases = %d: the matrix converter drives three phases", ph);
        if (cfg->inverter.kind != FS_INV_AVERAGED)
            FAIL("converter.inverter = switching: the matrix converter's inverter stage is averaged per rectifier interval");
        if (cfg->inverter.u_on != 0.0 || cfg->inverter.r_on != 0.0)
            FAIL("converter.u_on = %g, r_on = %g: the matrix converter's drops are its devices' (inverter.dev); must be 0",
                 cfg->inverter.u_on, cfg->inverter.r_on);
        if (cfg->sampling != FS_SAMPLING_SINGLE) FAIL("timing.sampling: the matrix converter samples once per period (single)");
        if (fs_grid_check(&cfg->grid) != 0)
            FAIL("converter.grid: V_im, f_grid, L_f, R_f, C_f must be > 0 (got %g V, %g Hz, %g H, %g ohm, %g F)",
                 cfg->grid.V_im, cfg->grid.f_grid, cfg->grid.L_f, cfg->grid.R_f, cfg->grid.C_f);
        fs_grid_initial_state(&cfg->grid, s->g);
        /* until the drive's first rectifier command: phases a and b, whole period */
        s->rect_now.iv[0] = (fs_imc_interval){0, 1, 1.0f};
        s->rect_next = s->rect_now;
    }
    s->phases = ph;
    s->nx = ph == 5 ? FS_X_N5 : FS_X_N3;
    s->losses = cfg->plant.losses != 0;
    s->imc_real = s->imc && (cfg->inverter.dev.enabled || cfg->inverter.t_dead > 0.0 || s->losses);
    for (int k = 0; k < FS_INV_MAX_LEGS; ++k) s->leg_state[k] = -2;
    fs_status pst = fs_pmsm_init(&s->pmsm, &cfg->plant);
    if (pst != FS_OK)
        FAIL("machine: %s%s", fs_status_str(pst), fs_iron_check(&cfg->plant.iron) != FS_OK
             ? " (the iron loss: P_ref >= 0; with it w_ref, psi_ref, w_band > 0, k_hyst in [0, 1], beta in [1, 3])" : "");
    if (s->pmsm.harm && fc->open_phase)
        FAIL("faults.open_phase = %d: not modelled with spatial harmonics (machine [harmonics])", fc->open_phase);
    s->Tc = cfg->sampling == FS_SAMPLING_DOUBLE ? 0.5 * cfg->inverter.T_pwm : cfg->inverter.T_pwm;
    if (fabs(cfg->drive.Ts - s->Tc) > 1e-6 * s->Tc)
        FAIL("controller.Ts = %g: must equal the control period %g", cfg->drive.Ts, s->Tc);
    fs_status st = fs_drive_init(&s->drive, &cfg->drive);
    if (st != FS_OK) FAIL("controller.%s: %s", s->drive.fail ? s->drive.fail : "?", fs_status_str(st));

    fs_pmsm_initial_state(&s->pmsm, s->x);
    s->x[FS_X_THETA_M] = cfg->theta_m0;
    s->x[FS_X_W_M] = cfg->w_m0;
    fs_pmsm_rest_flux(&s->pmsm, s->x);   /* spatial harmonics: zero current at theta_m0 */
    if (cfg->plant.load_kind == FS_LOAD_SPEED_IDEAL)
        s->x[FS_X_W_M] = prof(s, P_W_LOAD, 0.0, NULL);
    for (int k = 0; k < FS_INV_MAX_LEGS; ++k) s->duty_now[k] = s->duty_next[k] = 0.5;
    s->rng = cfg->seed ? cfg->seed : 0x9E3779B97F4A7C15ULL;
    s->stop_time = NAN;
    s->adc_sat_time = NAN;
    for (int k = 0; k < FS_INV_MAX_LEGS; ++k)
        s->sensor_fault |= cfg->fault.i_gain[k] != 0.0 || cfg->fault.i_offset[k] != 0.0;
    s->adc_clip_only = !s->sensor_fault && !(cfg->noise_i > 0.0) && !(cfg->adc_bits > 0);
    const fs_inverter_config *inv = &cfg->inverter;
    s->inv_ideal = inv->t_dead == 0.0 && inv->u_on == 0.0 && inv->r_on == 0.0 && !inv->dev.enabled;
    s->half_steps = substeps(0.5 * inv->T_pwm, cfg->h_max);
    s->half_h = 0.5 * inv->T_pwm / s->half_steps;
    s->avg_ideal = inv->kind != FS_INV_SWITCHING && s->inv_ideal && !s->losses;
    s->u_dc0 = cfg->inverter.u_dc;
    s->psi_f_true = cfg->plant.mag.psi_f;
    s->k_mag = 1.0;
    if (cfg->thermal.enabled) {
        if (cfg->plant.mag.kind == FS_MAG_FLUXMAP)
            FAIL("thermal: a flux map's magnet temperature is not modelled (use the linear or algebraic model)");
        if (fs_thermal_init(&s->thermal, &cfg->thermal) != FS_OK)
            FAIL("thermal: a field is out of range (resistances and capacities > 0, time_scale >= 1, shares in [0, 1], "
                 "|alpha| < 0.1/K, temperatures in [-273.15, 1000] degC)");
        s->thermal_on = 1;
        thermal_apply(s);
    }
    s->held_group[G_IMC] = !s->imc;
    s->held_group[G_THERMAL] = !s->thermal_on;   /* R_s and the magnet move with it alone */
    s->held_group[G_METERS] = !s->losses && !s->imc;
    s->held_group[G_LOSSES] = !s->losses;
    s->held_group[G_FIVE] = s->phases != 5;
    s->held_group[G_ADAPT] = !(cfg->drive.adapt.T_f > 0.0f);
    return s;
}

/* The plant's R_s and magnet at the thermal model's temperatures; the
 * magnet (a flux solve) only when its factor moved by 1e-6 or more. */
static void thermal_apply(fs_sim *s)
{
    const double r = fs_thermal_r_factor(&s->thermal), k = fs_thermal_magnet_factor(&s->thermal);
    if (fabs(k - s->k_mag) >= 1e-6) {
        fs_pmsm_set_temperature(&s->pmsm, s->x, r, k);
        s->k_mag = k;
        double pq;
        fs_mag_flux(&s->pmsm.mag, 0.0, 0.0, &s->psi_f_true, &pq);
    } else {
        s->pmsm.cfg.R_s = r * s->pmsm.R_s0;
    }
}

/* The thermal model over the period that ended: the copper loss from the
 * plant's meter, the iron loss at the period's end. */
static void thermal_period(fs_sim *s)
{
    const double P_cu = (s->x[FS_X_E_CU] - s->e_cu_prev) / s->Tc;
    s->e_cu_prev = s->x[FS_X_E_CU];
    const fs_iron_config *fe = &s->thermal.cfg.iron;   /* psi_ref: the magnet's flux; a machine without magnet: at it */
    const double psi = s->pmsm.mag.psi_f0 > 0.0 ? hypot(s->x[FS_X_PSI_D], s->x[FS_X_PSI_Q]) : fe->psi_ref;
    const double P_fe = fe->P_ref > 0.0 ? fs_iron_loss(fe, s->pmsm.cfg.pole_pairs * s->x[FS_X_W_M], psi) : 0.0;
    fs_thermal_step(&s->thermal, P_cu, P_fe, s->Tc);
    thermal_apply(s);
}

void fs_sim_destroy(fs_sim *s)
{
    if (!s) return;
    for (int p = 0; p < P_N; ++p) fs_pwl_free(&s->prof[p]);
    free(s);
}

double fs_sim_time(const fs_sim *s) { return s ? (double)s->k * s->Tc : NAN; }
long long fs_sim_step_count(const fs_sim *s) { return s ? s->k : -1; }

long long fs_sim_steps(const fs_sim *s, double t)
{
    if (!s) return 0;
    const double n = ceil(t / s->Tc - 0.5);
    if (!(n > 0.0)) return 0;                  /* t <= Tc / 2, or NaN */
    return n < 0x1p62 ? (long long)n : (long long)0x1p62;   /* beyond any duration the schema allows */
}
double fs_sim_stop_time(const fs_sim *s) { return s ? s->stop_time : NAN; }
double fs_sim_adc_saturated_at(const fs_sim *s) { return s ? s->adc_sat_time : NAN; }

const fs_drive *fs_sim_drive(const fs_sim *s) { return s ? &s->drive : NULL; }

/* RK4 steps of at most h_max over an interval T (<= T_pwm, so the count
 * fits an int: fs_sim_create). T is NaN when the drive's duties are (the
 * switching instants are NaN): one step then carries the NaN into the
 * state, for the NaN stop, instead of a cast of NaN to int. */
static int substeps(double T, double h_max)
{
    const double n = ceil(T / h_max - 1e-9);
    return isnan(n) ? 1 : (int)n;
}

/* The converter's meters (fs_sim.h) over a stretch in which each leg k sat
 * on rail[k] (its mean, averaged) with its devices dropping drop[k]: the
 * phase currents' integrals from the plant's stationary ones, which the
 * caller cleared at the stretch's start. */
static void meter_legs(fs_sim *s, const double *rail, const double *drop)
{
    const double *I = &s->x[FS_X_I_A_INT];
    double dI[FS_INV_MAX_LEGS];
    if (s->phases == 5) fs_inverter_vsd5_inverse(I[0], I[1], I[2], I[3], 0.0, dI);
    else inv_clarke3(I[0], I[1], dI);
    for (int k = 0; k < s->phases; ++k) {
        s->e_dc += s->cfg.inverter.u_dc * rail[k] * dI[k];
        s->e_cond += drop[k] * dI[k];
    }
}

static void clear_current_integrals(fs_sim *s)
{
    for (int n = FS_X_I_A_INT; n <= FS_X_I_Y_INT; ++n) s->x[n] = 0.0;
}

/* Commutation energy, which the converter's source supplies. */
static void commutations(fs_sim *s, double E)
{
    s->e_sw += E;
    s->e_dc += E;
}

/* The phase currents of the state as it is (and in a its angle's cosine and
 * sine and rotor-frame currents, for the step from it): those the
 * overcurrent check left if cur_ok (its first use in the period: the state
 * has not moved since), else computed. */
static void currents_now(fs_sim *s, int *cur_ok, double *i_ph, fs_pmsm_at *a)
{
    if (*cur_ok) {
        for (int k = 0; k < FS_INV_MAX_LEGS; ++k) i_ph[k] = s->cur_ph[k];
        *a = s->cur_at;
        *cur_ok = 0;
    } else {
        phase_currents_at(s, s->x, i_ph, a);
    }
}

/* The period's load and open phase, the plant's inputs but the voltage. */
FS_SPECIALISE void period_input(fs_sim *s, double t0, fs_pmsm_input *in)
{
    double slope;
    if (s->cfg.fault.open_phase && t0 >= s->cfg.fault.t_open) {
        in->open_phase = s->cfg.fault.open_phase;
        in->tau_open = 3.0 * s->cfg.h_max;   /* the interrupted current falls in a few steps */
    }
    in->T_load = prof(s, P_T_LOAD, t0, NULL);
    in->w_load = prof(s, P_W_LOAD, t0, &slope);
    in->dw_load = slope;
}

/* integrate_period_general's for the averaged inverter without dead time, drops, devices or meters (the
 * wall bench's example: s->avg_ideal): its mean voltage is a function of the duties and the dc link alone,
 * which no half of the period changes, so it is formed once for the period (the general path forms it
 * again for the second half, the same bits: two divisions on the way to the first RK4 stage). The steps
 * are the general path's, in its order: the first takes the overcurrent check's angle and currents. */
FS_SPECIALISE void integrate_period_ideal(fs_sim *s, double t0, int cur_ok)
{
    fs_pmsm_input in = {0};
    period_input(s, t0, &in);
    fs_inverter_mean_voltage_ideal(&s->cfg.inverter, s->duty_now, &in.u_alpha, &in.u_beta, &in.u_x, &in.u_y);
    const int steps = (s->cfg.sampling == FS_SAMPLING_DOUBLE ? 1 : 2) * s->half_steps;
    const double hstep = s->half_h;
    const fs_pmsm_at *at = cur_ok ? &s->cur_at : NULL;
    for (int m = 0; m < steps; ++m) fs_pmsm_rk4_at(&s->pmsm, s->x, &in, hstep, m == 0 ? at : NULL);
}

/* Integrate the plant over one control period with the duties now acting;
 * cur_ok: the overcurrent check's currents are the state's (currents_now). */
static void integrate_period_general(fs_sim *s, double t0, int cur_ok)
{
    const fs_inverter_config *inv = &s->cfg.inverter;
    fs_pmsm_input in = {0};
    period_input(s, t0, &in);
    const int halves = s->cfg.sampling == FS_SAMPLING_DOUBLE ? 1 : 2;
    double i_ph[FS_INV_MAX_LEGS], rail[FS_INV_MAX_LEGS], drop[FS_INV_MAX_LEGS];
    int half0 = s->cfg.sampling == FS_SAMPLING_DOUBLE ? (int)(s->k & 1) : 0;
    for (int h = 0; h < halves; ++h) {
        int half = half0 + h;
        if (inv->kind == FS_INV_SWITCHING) {
            fs_inv_segments seg;
            fs_inverter_segments(inv, s->duty_now, half, &seg);
            for (int n = 0; n < seg.n; ++n) {
                fs_pmsm_at at;
                currents_now(s, &cur_ok, i_ph, &at);
                fs_inverter_voltage(inv, seg.state[n], i_ph, &in.u_alpha, &in.u_beta, &in.u_x, &in.u_y);
                /* a dead time that ends on the rail its diode held: its voltage
                 * and the next segment's are one, integrated as one stretch in
                 * steps of at most h_max (only without drops and devices: no
                 * commutation energy, and each leg on one rail throughout,
                 * its dead time's diode's, for the meters) */
                const int span = fs_inverter_same_voltage(inv, &seg, n, i_ph);
                if (s->losses) {   /* the edges at this segment's start, and its legs */
                    commutations(s, fs_inverter_commutations(inv, s->leg_state, seg.state[n], i_ph));
                    for (int k = 0; k < s->phases; ++k) s->leg_state[k] = seg.state[n + span - 1][k];
                    fs_inverter_legs(inv, seg.state[n], i_ph, rail, drop);
                    clear_current_integrals(s);
                }
                double dt = seg.dt[n];
                for (int j = 1; j < span; ++j) dt += seg.dt[n + j];
                n += span - 1;
                int steps = substeps(dt, s->cfg.h_max);
                double hstep = dt / steps;
                for (int m = 0; m < steps; ++m) fs_pmsm_rk4_at(&s->pmsm, s->x, &in, hstep, m == 0 ? &at : NULL);
                if (s->losses) meter_legs(s, rail, drop);
            }
        } else {
            const int steps = s->half_steps;
            const double hstep = s->half_h;
            if (s->losses) {   /* one edge of each switching leg in the half period: low to high in the first */
                int before[FS_INV_MAX_LEGS], after[FS_INV_MAX_LEGS];
                for (int k = 0; k < s->phases; ++k) {
                    const double d = s->duty_now[k];
                    before[k] = d > 0.0 && d < 1.0 ? half == 1 : d >= 1.0;
                    after[k] = d > 0.0 && d < 1.0 ? !before[k] : before[k];
                }
                fs_pmsm_at at;
                currents_now(s, &cur_ok, i_ph, &at);
                commutations(s, fs_inverter_commutations(inv, before, after, i_ph));
            }
            /* the mean voltage depends on the currents only through dead time
             * and drops: without them it is one value for the half period */
            const int ideal = s->inv_ideal;
            if (ideal) {
                for (int k = 0; k < FS_INV_MAX_LEGS; ++k) i_ph[k] = 0.0;
                fs_inverter_mean_voltage_ideal(inv, s->duty_now, &in.u_alpha, &in.u_beta, &in.u_x, &in.u_y);
                if (s->losses) fs_inverter_mean_legs(inv, s->duty_now, i_ph, rail, drop);
            }
            for (int m = 0; m < steps; ++m) {
                fs_pmsm_at at;
                const fs_pmsm_at *first = NULL;   /* the step's first stage: the state's angle and currents */
                if (!ideal) {
                    currents_now(s, &cur_ok, i_ph, &at);
                    fs_inverter_mean_voltage(inv, s->duty_now, i_ph, &in.u_alpha, &in.u_beta, &in.u_x,
                                             &in.u_y);
                    if (s->losses) fs_inverter_mean_legs(inv, s->duty_now, i_ph, rail, drop);
                    first = &at;
                } else if (cur_ok) {   /* the overcurrent check's, as the switching model takes them: the same bits */
                    at = s->cur_at;
                    cur_ok = 0;
                    first = &at;
                }
                if (s->losses) clear_current_integrals(s);
                fs_pmsm_rk4_at(&s->pmsm, s->x, &in, hstep, first);
                if (s->losses) meter_legs(s, rail, drop);
            }
        }
    }
}

/* The period: the ideal averaged inverter's path inline in the runner's loop, the rest a call. */
FS_SPECIALISE void integrate_period(fs_sim *s, double t0, int cur_ok)
{
    if (s->avg_ideal) integrate_period_ideal(s, t0, cur_ok);
    else integrate_period_general(s, t0, cur_ok);
}

/* Matrix converter, one rectifier interval: the rails on input phases p
 * and n, the inverter legs' duties f. In the stationary frame, with c_k the
 * unit vector of phase k and w = c_p - c_n: v_pn = w.v_c, the machine's
 * voltage is f_ab v_pn (f_ab the Clarke of the duties), the dc-link current
 * i_dc = sum f_k i_k = 3/2 f_ab.i_ab, and the rectifier draws i_in = 2/3 w
 * i_dc from the filter. All but the states are constant over the interval. */
typedef struct {
    double f_a, f_b;          /* Clarke of the duties */
    double w_a, w_b;          /* c_p - c_n */
    /* imc_deriv_real: the stage as an inverter whose period is the
     * interval (its dead time and devices), its duties, and the power its
     * commutations take over the interval */
    fs_inverter_config stage;
    const double *f;
    double p_sw;
} imc_interval;

static imc_interval imc_interval_of(const double *f, int p, int n)
{
    const double c_a[3] = {1.0, -0.5, -0.5}, c_b[3] = {0.0, 0.5 * sqrt(3.0), -0.5 * sqrt(3.0)};
    imc_interval iv = {0};
    iv.f_a = (2.0 * f[0] - f[1] - f[2]) / 3.0;
    iv.f_b = (f[1] - f[2]) / sqrt(3.0);
    iv.w_a = c_a[p] - c_a[n];
    iv.w_b = c_b[p] - c_b[n];
    return iv;
}

/* The right-hand side of the machine, the filter and the period meters. */
static void imc_deriv(fs_sim *s, double t, const double *x, const double *g, const imc_interval *iv,
                      const fs_pmsm_input *in, double *dx, double *dg, double *dm)
{
    const double v_pn = iv->w_a * g[FS_GRID_X_VC_A] + iv->w_b * g[FS_GRID_X_VC_B];
    fs_pmsm_input pin = *in;
    pin.u_alpha = iv->f_a * v_pn;
    pin.u_beta = iv->f_b * v_pn;
    pin.u_x = pin.u_y = 0.0;
    fs_pmsm_deriv(&s->pmsm, x, &pin, dx);
    double i_a, i_b;
    stator_current(s, x, &i_a, &i_b, NULL, NULL);
    const double i_dc = 1.5 * (iv->f_a * i_a + iv->f_b * i_b);
    double ig_a;
    fs_grid_deriv(&s->cfg.grid, t, g, 2.0 / 3.0 * iv->w_a * i_dc, 2.0 / 3.0 * iv->w_b * i_dc, dg, &ig_a);
    dm[0] = ig_a;
    dm[1] = v_pn;
    dm[2] = 1.5 * pin.u_alpha - 0.5 * sqrt(3.0) * pin.u_beta;   /* u_A - u_B */
}

/* The rectifier path's drop at dc-link current i: two bidirectional
 * switches, each a transistor and a diode in series (a MOSFET switch: two
 * channels). */
static double rectifier_drop(const fs_device_config *d, double i)
{
    if (!d->enabled) return 0.0;
    return 2.0 * (fs_device_drop(d, 1, i) + fs_device_drop(d, d->kind == FS_DEV_MOSFET, i));
}

/* imc_deriv with the devices, the dead time and the meters (fs_sim.h):
 * each leg k on the p rail for its share s_k of the interval (its duty less
 * the dead time's share) with its devices' mean drop, the rectifier's drop
 * taken from v_pn, and the commutations' power drawn from the filter. The
 * meters beyond imc_deriv's: E_DC, E_RECT, E_COND, E_SW. */
static void imc_deriv_real(fs_sim *s, double t, const double *x, const double *g, const imc_interval *iv,
                           const fs_pmsm_input *in, double *dx, double *dg, double *dm)
{
    const double v_pn = iv->w_a * g[FS_GRID_X_VC_A] + iv->w_b * g[FS_GRID_X_VC_B];
    double i_a, i_b, i_ph[3], rail[3], drop[3];
    stator_current(s, x, &i_a, &i_b, NULL, NULL);
    inv_clarke3(i_a, i_b, i_ph);
    fs_inverter_mean_legs(&iv->stage, iv->f, i_ph, rail, drop);
    double i_dc = 0.0, p_cond = 0.0;
    for (int k = 0; k < 3; ++k) {
        i_dc += rail[k] * i_ph[k];
        p_cond += drop[k] * i_ph[k];
    }
    const double d_rect = rectifier_drop(&iv->stage.dev, i_dc), v_eff = v_pn - d_rect;
    double v[3];
    for (int k = 0; k < 3; ++k) v[k] = rail[k] * v_eff - drop[k];
    fs_pmsm_input pin = *in;
    pin.u_alpha = (2.0 * v[0] - v[1] - v[2]) / 3.0;
    pin.u_beta = (v[1] - v[2]) / sqrt(3.0);
    pin.u_x = pin.u_y = 0.0;
    fs_pmsm_deriv(&s->pmsm, x, &pin, dx);
    const double i_sw = v_pn > 0.0 ? iv->p_sw / v_pn : 0.0;   /* v_pn > 0 but at the grid's start */
    double ig_a;
    fs_grid_deriv(&s->cfg.grid, t, g, 2.0 / 3.0 * iv->w_a * (i_dc + i_sw), 2.0 / 3.0 * iv->w_b * (i_dc + i_sw), dg,
                  &ig_a);
    dm[0] = ig_a;
    dm[1] = v_pn;
    dm[2] = v[0] - v[1];   /* u_A - u_B */
    dm[3] = v_pn * (i_dc + i_sw);
    dm[4] = d_rect * i_dc;
    dm[5] = p_cond;
    dm[6] = v_pn * i_sw;
}

/* RK4's increment of one state from its four slopes, h/6 (k0 + 2 k1 + 2 k2 + k3) */
static inline double rk4_increment(double h, double k0, double k1, double k2, double k3)
{
    return h / 6.0 * (k0 + 2.0 * k1 + 2.0 * k2 + k3);
}

/* One RK4 step of the machine, the filter and the meters together. */
static void imc_rk4(fs_sim *s, double t, const imc_interval *iv, const fs_pmsm_input *in, double h)
{
    enum { NX = FS_X_N, NG = FS_GRID_X_N, NM = 7 };
    const int nx = s->nx;
    double kx[4][NX], kg[4][NG], km[4][NM], x[NX], g[NG];
    const double c[4] = {0.0, 0.5, 0.5, 1.0};
    for (int st = 0; st < 4; ++st) {
        for (int k = 0; k < nx; ++k) x[k] = s->x[k] + (st ? c[st] * h * kx[st - 1][k] : 0.0);
        if (s->losses)
            for (int k = FS_X_N5; k < NX; ++k) x[k] = s->x[k] + (st ? c[st] * h * kx[st - 1][k] : 0.0);
        for (int k = 0; k < NG; ++k) g[k] = s->g[k] + (st ? c[st] * h * kg[st - 1][k] : 0.0);
        if (s->imc_real) imc_deriv_real(s, t + c[st] * h, x, g, iv, in, kx[st], kg[st], km[st]);
        else imc_deriv(s, t + c[st] * h, x, g, iv, in, kx[st], kg[st], km[st]);
    }
    for (int k = 0; k < nx; ++k) s->x[k] += rk4_increment(h, kx[0][k], kx[1][k], kx[2][k], kx[3][k]);
    if (s->losses)
        for (int k = FS_X_N5; k < NX; ++k) s->x[k] += rk4_increment(h, kx[0][k], kx[1][k], kx[2][k], kx[3][k]);
    for (int k = 0; k < NG; ++k) s->g[k] += rk4_increment(h, kg[0][k], kg[1][k], kg[2][k], kg[3][k]);
    for (int k = 0; k < 3; ++k) s->g_int[k] += rk4_increment(h, km[0][k], km[1][k], km[2][k], km[3][k]);
    if (s->imc_real) {   /* the meters imc_deriv_real alone sets */
        s->e_dc += rk4_increment(h, km[0][3], km[1][3], km[2][3], km[3][3]);
        s->e_rect += rk4_increment(h, km[0][4], km[1][4], km[2][4], km[3][4]);
        s->e_cond += rk4_increment(h, km[0][5], km[1][5], km[2][5], km[3][5]);
        s->e_sw += rk4_increment(h, km[0][6], km[1][6], km[2][6], km[3][6]);
    }
}

/* Matrix converter: the period's two rectifier intervals in turn. */
static void integrate_period_imc(fs_sim *s, double t0)
{
    fs_pmsm_input in = {0};
    double slope;
    in.T_load = prof(s, P_T_LOAD, t0, NULL);
    in.w_load = prof(s, P_W_LOAD, t0, &slope);
    in.dw_load = slope;
    s->g_int[0] = s->g_int[1] = s->g_int[2] = 0.0;
    double t = t0;
    for (int v = 0; v < 2; ++v) {
        const fs_imc_interval *r = &s->rect_now.iv[v];
        const double T = fmin(fmax((double)r->d, 0.0), 1.0) * s->Tc;
        if (T <= 0.0) continue;
        imc_interval iv = imc_interval_of(s->duty_now, r->p, r->n);
        if (s->imc_real) {   /* the stage over this interval; its legs switch up and down once in it */
            iv.stage = s->cfg.inverter;
            iv.stage.T_pwm = T;
            iv.f = s->duty_now;
            double i_a, i_b, i_ph[3];
            stator_current(s, s->x, &i_a, &i_b, NULL, NULL);
            inv_clarke3(i_a, i_b, i_ph);
            int low[3], high[3];   /* -1: a leg that does not switch */
            for (int k = 0; k < 3; ++k) {
                const int sw = s->duty_now[k] > 0.0 && s->duty_now[k] < 1.0;
                low[k] = sw ? 0 : -1;
                high[k] = sw ? 1 : -1;
            }
            iv.stage.u_dc = iv.w_a * s->g[FS_GRID_X_VC_A] + iv.w_b * s->g[FS_GRID_X_VC_B];
            const double E = fs_inverter_commutations(&iv.stage, low, high, i_ph)
                             + fs_inverter_commutations(&iv.stage, high, low, i_ph);
            iv.p_sw = E / T;
        }
        const int steps = substeps(T, s->cfg.h_max);
        const double h = T / steps;
        for (int m = 0; m < steps; ++m) {
            imc_rk4(s, t, &iv, &in, h);
            t += h;
        }
    }
}

/* The devices' conduction loss at phase currents i_ph, W: each leg's
 * conducting device (switch or diode) drops sign(i) u_on + r_on i. The
 * matrix converter's model has no drops. */
static double conduction_loss(const fs_sim *s, const double *i_ph)
{
    const fs_inverter_config *inv = &s->cfg.inverter;
    if (s->imc || (inv->u_on == 0.0 && inv->r_on == 0.0)) return 0.0;
    double p = 0.0;
    for (int k = 0; k < s->phases; ++k) p += fabs(i_ph[k]) * (inv->u_on + inv->r_on * fabs(i_ph[k]));
    return p;
}

/* The sampling instant at t: the true phase currents, in a the angle's
 * cosine and sine and the rotor-frame currents (fs_pmsm_at_state), and the
 * drive's inputs as the hardware gives them (the sensors, the dc link, the
 * references and the load machine's speed at t). */
FS_SPECIALISE void sample(fs_sim *s, double t, fs_drive_in *din, double *i_ph, fs_pmsm_at *a)
{
    const fs_sim_config *c = &s->cfg;
    const int p = c->plant.pole_pairs;
    double slope;
    if (c->plant.load_kind == FS_LOAD_SPEED_IDEAL)
        s->x[FS_X_W_M] = prof(s, P_W_LOAD, t, &slope);

    /* the dc link over this period (the inverter's; a sag or a step) */
    if (!s->imc && (s->prof[P_U_DC_SCALE].n > 0 || s->held[P_U_DC_SCALE]))
        s->cfg.inverter.u_dc = s->u_dc0 * prof(s, P_U_DC_SCALE, t, NULL);

    if (s->cur_ok) {
        for (int k = 0; k < FS_INV_MAX_LEGS; ++k) i_ph[k] = s->cur_ph[k];
        *a = s->cur_at;
    } else {
        phase_currents_at(s, s->x, i_ph, a);
    }
    /* the phases beyond the machine's read 0: all cleared, then the phases', a constant count of
     * stores where the phases' count was a call to memset */
    for (int k = 0; k < FS_PHASES_MAX; ++k) din->i_ph[k] = 0.0f;
    if (s->adc_clip_only) {
        for (int k = 0; k < s->phases; ++k) din->i_ph[k] = (float)adc_clip(s, i_ph[k], t);
    } else {
        for (int k = 0; k < s->phases; ++k) din->i_ph[k] = (float)adc(s, k, i_ph[k], t);
    }
    din->u_dc = (float)c->inverter.u_dc;
    if (s->imc) {
        double u_in[3];
        inv_clarke3(s->g[FS_GRID_X_VC_A], s->g[FS_GRID_X_VC_B], u_in);
        for (int k = 0; k < 3; ++k) din->u_in[k] = (float)u_in[k];
        if (s->k > 0) din->u_dc = (float)(s->g_int[1] / s->Tc);
    } else {
        din->u_in[0] = din->u_in[1] = din->u_in[2] = 0.0f;
    }
    if (!(c->fault.t_encoder_stop > 0.0 && t >= c->fault.t_encoder_stop))
        s->theta_enc_held = (float)encoder(s, s->x[FS_X_THETA_M]);
    din->theta_m_enc = s->theta_enc_held;
    s->theta_e = wrap_pi(p * s->x[FS_X_THETA_M]);
    din->theta_e_ext = (float)s->theta_e;
    din->w_e_ext = (float)(p * s->x[FS_X_W_M]);
    din->w_m_ref = (float)prof(s, P_W_M_REF, t, NULL);
    din->i_d_ref = (float)prof(s, P_I_D_REF, t, NULL);
    din->i_q_ref = (float)prof(s, P_I_Q_REF, t, NULL);
    din->u_d_ref = (float)prof(s, P_U_D_REF, t, NULL);
    din->u_q_ref = (float)prof(s, P_U_Q_REF, t, NULL);
    din->w_e_ref = (float)prof(s, P_W_E_REF, t, NULL);
    din->sensorless = prof(s, P_SENSORLESS, t, NULL) > 0.5;
    s->e_in0 = s->x[FS_X_E_IN];
    s->e_dc0 = s->e_dc;
    s->p_cond0 = conduction_loss(s, i_ph);
}

/* The duties (and rectifier intervals) the drive computed at this sample:
 * at once without the computation delay, else at the next update. */
static void command(fs_sim *s, const float *duty, const fs_imc_rect *rect)
{
    for (int k = 0; k < s->phases; ++k) s->duty_next[k] = duty[k];
    if (rect && s->imc) s->rect_next = *rect;   /* read by the matrix converter alone */
    if (!s->cfg.delay) {
        for (int k = 0; k < s->phases; ++k) s->duty_now[k] = s->duty_next[k];
        if (s->imc) s->rect_now = s->rect_next;
    }
}

/* A trace row's channels go to r[FS_CH_* * st]: st 1 row-major, else the
 * column-major trace's stride. The row writers are specialised by it (the
 * row-major one multiplies by no stride). */

/* Channels that a run's configuration can hold constant (enum G_*, at the
 * top), in groups: the matrix converter's (0 without it), the thermal
 * model's (without it), the converter's meters (0 without loss meters and
 * matrix converter), the machine's loss meters (0 without), the
 * third-harmonic currents (0 with three phases), the controller's corrected
 * R_s and psi_f (its configured ones without the correction). A group's
 * values as a row writes them: */
static const int GROUP_N[G_N] = {6, 4, 4, 3, 2, 2};
static const int GROUP_CH[G_N][G_MAX] = {
    {FS_CH_I_GRID_A, FS_CH_V_PN, FS_CH_U_AB, FS_CH_E_GRID, FS_CH_E_RF, FS_CH_W_FILTER},
    {FS_CH_T_WINDING, FS_CH_T_MAGNET, FS_CH_R_S_TRUE, FS_CH_PSI_F_TRUE},
    {FS_CH_E_DC, FS_CH_E_COND, FS_CH_E_RECT, FS_CH_E_SW},
    {FS_CH_E_FE, FS_CH_E_MECH, FS_CH_E_SHAFT},
    {FS_CH_I_D3, FS_CH_I_Q3},
    {FS_CH_R_S_HAT, FS_CH_PSI_F_HAT}};

FS_SPECIALISE void group_values(const fs_sim *s, const int g, double *v)
{
    const fs_sim_config *c = &s->cfg;
    if (g == G_IMC) {
        const int imc_mean = s->imc && s->k > 0;
        v[0] = imc_mean ? s->g_int[0] / s->Tc : 0.0;
        v[1] = imc_mean ? s->g_int[1] / s->Tc : 0.0;
        v[2] = imc_mean ? s->g_int[2] / s->Tc : 0.0;
        v[3] = s->imc ? s->g[FS_GRID_X_E_GRID] : 0.0;
        v[4] = s->imc ? s->g[FS_GRID_X_E_RF] : 0.0;
        v[5] = s->imc ? fs_grid_energy(&c->grid, s->g) : 0.0;
    } else if (g == G_THERMAL) {
        v[0] = s->thermal_on ? s->thermal.T_w : 0.0;
        v[1] = s->thermal_on ? s->thermal.T_m : 0.0;
        v[2] = s->pmsm.cfg.R_s;
        v[3] = s->psi_f_true;
    } else if (g == G_METERS) {
        v[0] = s->e_dc;
        v[1] = s->e_cond;
        v[2] = s->e_rect;
        v[3] = s->e_sw;
    } else if (g == G_LOSSES) {
        v[0] = s->losses ? s->x[FS_X_E_FE] : 0.0;
        v[1] = s->losses ? s->x[FS_X_E_MECH] : 0.0;
        v[2] = s->losses ? s->x[FS_X_E_SHAFT] : 0.0;
    } else if (g == G_FIVE) {
        fs_pmsm_currents3(&s->pmsm, s->x, &v[0], &v[1]);
    } else {
        const int adapt = c->drive.adapt.T_f > 0.0f;
        v[0] = adapt ? s->drive.adapt.R_s : c->drive.R_s;
        v[1] = adapt ? s->drive.adapt.psi_f : c->drive.psi_f;
    }
}

/* Group g's channels of a row, unless the column-major trace (all 0) gets
 * them from fill_held: where the configuration holds them (s->held_group). */
FS_SPECIALISE void row_group(const fs_sim *s, const int g, double *r, const long st, const int all)
{
    if (all || !s->held_group[g]) {
        double v[G_MAX];
        group_values(s, g, v);
        for (int i = 0; i < GROUP_N[g]; ++i) r[GROUP_CH[g][i] * st] = v[i];
    }
}

/* The held groups' columns of the n rows a column-major chunk wrote from
 * trace: one fill a channel, the values a row would have had. */
static void fill_held(const fs_sim *s, double *trace, long stride, int n)
{
    for (int g = 0; g < G_N; ++g) {
        if (!s->held_group[g]) continue;
        double v[G_MAX];
        group_values(s, g, v);
        for (int i = 0; i < GROUP_N[g]; ++i) {
            double *col = trace + (size_t)GROUP_CH[g][i] * (size_t)stride;
            if (v[i] == 0.0 && !signbit(v[i])) {
                memset(col, 0, sizeof(double) * (size_t)n);   /* +0.0 is all zero bits (IEEE 754) */
            } else {
                for (int k = 0; k < n; ++k) col[k] = v[i];
            }
        }
    }
}

/* The plant's channels of a trace row at time t (the state as it is, its
 * wrapped electrical angle theta_e, its phase currents i_ph and a as
 * phase_currents_at gives them; u_dc the dc link sampled at t), the drive's
 * left as they are. */
FS_SPECIALISE void row_plant(fs_sim *s, double t, double theta_e, const double *i_ph, const fs_pmsm_at *a,
                             double u_dc, double *r, const long st, const int all)
{
    fs_pmsm_input pin = {0};
    pin.T_load = prof(s, P_T_LOAD, t, NULL);
    pin.w_load = prof(s, P_W_LOAD, t, NULL);
    double Te, Tl, id2, iq2;
    fs_pmsm_outputs_at(&s->pmsm, s->x, &pin, a, &id2, &iq2, &Te, &Tl);
    r[FS_CH_T * st] = t;
    r[FS_CH_THETA_E * st] = theta_e;
    r[FS_CH_W_M * st] = s->x[FS_X_W_M];
    r[FS_CH_PSI_D * st] = s->x[FS_X_PSI_D];
    r[FS_CH_PSI_Q * st] = s->x[FS_X_PSI_Q];
    r[FS_CH_I_D * st] = a->i_d;
    r[FS_CH_I_Q * st] = a->i_q;
    r[FS_CH_I_A * st] = i_ph[0];
    r[FS_CH_I_B * st] = i_ph[1];
    r[FS_CH_I_C * st] = i_ph[2];
    r[FS_CH_T_E * st] = Te;
    r[FS_CH_T_L * st] = Tl;
    r[FS_CH_U_D * st] = s->k > 0 ? s->x[FS_X_UD_INT] / s->Tc : 0.0;
    r[FS_CH_U_Q * st] = s->k > 0 ? s->x[FS_X_UQ_INT] / s->Tc : 0.0;
    r[FS_CH_E_IN * st] = s->x[FS_X_E_IN];
    r[FS_CH_E_CU * st] = s->x[FS_X_E_CU];
    r[FS_CH_E_AIRGAP * st] = s->x[FS_X_E_AIRGAP];
    r[FS_CH_W_MAG * st] = fs_pmsm_energy(&s->pmsm, s->x);
    r[FS_CH_U_DC * st] = u_dc;
    row_group(s, G_FIVE, r, st, all);
    row_group(s, G_IMC, r, st, all);
    row_group(s, G_THERMAL, r, st, all);
    row_group(s, G_METERS, r, st, all);
    row_group(s, G_LOSSES, r, st, all);
}

/* The drive's channels of a trace row: its inputs and outputs at this
 * sample (theta_e: the true angle, as row_plant wrote it). */
FS_SPECIALISE void row_drive(const fs_sim *s, double theta_e, const fs_drive_in *din, const fs_drive_out *dout,
                             double *r, const long st, const int all)
{
    const fs_sim_config *c = &s->cfg;
    const int p = c->plant.pole_pairs;
    r[FS_CH_DUTY_A * st] = dout->duty[0];
    r[FS_CH_DUTY_B * st] = dout->duty[1];
    r[FS_CH_DUTY_C * st] = dout->duty[2];
    r[FS_CH_W_M_REF * st] = din->w_m_ref;
    r[FS_CH_I_D_REF * st] = dout->i_d_ref;
    r[FS_CH_I_Q_REF * st] = dout->i_q_ref;
    r[FS_CH_T_REF * st] = dout->T_ref;
    r[FS_CH_I_D_HAT * st] = dout->i_d;
    r[FS_CH_I_Q_HAT * st] = dout->i_q;
    r[FS_CH_U_D_REF * st] = dout->u_d;
    r[FS_CH_U_Q_REF * st] = dout->u_q;
    r[FS_CH_THETA_HAT * st] = dout->theta_e;
    r[FS_CH_W_M_HAT * st] = dout->w_e / p;
    r[FS_CH_THETA_ERR * st] = wrap_pi(theta_e - dout->theta_e);
    r[FS_CH_OVERMOD * st] = dout->over_modulation;
    r[FS_CH_THETA_EST * st] = dout->theta_est;
    r[FS_CH_W_M_EST * st] = dout->w_est / p;
    r[FS_CH_EST_VALID * st] = dout->est_valid;
    r[FS_CH_EST_ERR * st] = wrap_pi(theta_e - dout->theta_est);
    r[FS_CH_PHASE * st] = dout->phase;
    r[FS_CH_I_D_FW * st] = dout->i_d_fw;
    r[FS_CH_G_W * st] = dout->g_w;
    r[FS_CH_INJECT * st] = dout->injecting;
    r[FS_CH_I_HF_D * st] = dout->i_hf_d;
    r[FS_CH_I_HF_Q * st] = dout->i_hf_q;
    r[FS_CH_ALPHA * st] = dout->alpha;
    r[FS_CH_LOCK_RESID * st] = dout->lock_resid;
    r[FS_CH_LOCK_LOST * st] = dout->lock_lost;
    r[FS_CH_STAGE * st] = dout->stage;
    r[FS_CH_RECOVERIES * st] = dout->recoveries;
    row_group(s, G_ADAPT, r, st, all);
}

/* The plant over the period from the sample at t with the duties acting,
 * then the delayed duties and the checks: FS_RUN_DONE or a stop. */
FS_SPECIALISE int advance(fs_sim *s, double t)
{
    const fs_sim_config *c = &s->cfg;
    const int cur_ok = s->cur_ok;
    s->cur_ok = 0;
    s->x[FS_X_UD_INT] = s->x[FS_X_UQ_INT] = 0.0;
    if (s->imc) integrate_period_imc(s, t); else integrate_period(s, t, cur_ok);
    if (s->thermal_on) thermal_period(s);
    if (c->delay) {
        /* all the legs: those beyond the phases hold 0.5 in both (fs_sim_create, command), and a
         * copy of a constant count is a few moves where the phases' count was a call to memcpy */
        for (int k = 0; k < FS_INV_MAX_LEGS; ++k) s->duty_now[k] = s->duty_next[k];
        if (s->imc) s->rect_now = s->rect_next;
    }
    ++s->k;
    s->x[FS_X_THETA_M] = fmod_near(s->x[FS_X_THETA_M], 2.0 * pi_const());

    /* all states finite: x * 0 is 0 for a finite x and NaN for an infinite
     * or NaN one, so the sum is 0 or NaN (the filter's states move only with
     * the matrix converter). A three-phase machine's states are a constant
     * count (the loop unrolled), a five-phase one's two more. */
    double zero = 0.0;
    if (s->imc) for (int n = 0; n < FS_GRID_X_N; ++n) zero += s->g[n] * 0.0;
    for (int n = 0; n < FS_X_N3; ++n) zero += s->x[n] * 0.0;
    for (int n = FS_X_N3; n < s->nx; ++n) zero += s->x[n] * 0.0;
    if (zero != 0.0) {
        s->stopped = FS_STOP_NAN;
        s->stop_time = fs_sim_time(s);
        return s->stopped;
    }
    if (c->i_trip > 0.0) {
        double *i_ph = s->cur_ph;
        phase_currents_at(s, s->x, i_ph, &s->cur_at);
        s->cur_ok = s->pmsm.mag.cfg.kind != FS_MAG_FLUXMAP;
        /* all the legs, a constant count (unrolled): a three-phase machine's cur_ph[3], [4] are
         * never written and hold calloc's 0 */
        for (int k = 0; k < FS_INV_MAX_LEGS; ++k) {
            if (fabs(i_ph[k]) > c->i_trip) {
                s->stopped = FS_STOP_OVERCURRENT;
                s->stop_time = fs_sim_time(s);
                return s->stopped;
            }
        }
    }
    return FS_RUN_DONE;
}

/* The runner's loop: a recorded row goes to trace row-major (cols 0:
 * FS_CH_N doubles a row) or column-major (cols 1: channel c of row r at
 * trace[c * stride + r]). */
FS_SPECIALISE int run(fs_sim *s, long long k_end, double *trace, long stride, int max_rows, int *rows, const int cols)
{
    if (!s || !rows || (!trace && max_rows > 0)) return FS_RUN_ERR_NULL;
    *rows = 0;
    if (s->stopped) return s->stopped;
    const fs_sim_config *c = &s->cfg;
    while (s->k < k_end) {
        /* every sample at decimation 1 (the default): no 64-bit division a sample for it */
        const int record = (c->decimation == 1) || ((s->k % c->decimation) == 0);
        if (record && *rows >= max_rows) return FS_RUN_BUFFER_FULL;
        double t = (double)s->k * s->Tc;
        double i_ph[FS_INV_MAX_LEGS];
        fs_pmsm_at at;
        fs_drive_in din;
        sample(s, t, &din, i_ph, &at);
        fs_drive_out dout;
        memset(&dout, 0, sizeof dout);   /* the fields a mode leaves unwritten (ident_step) read 0, not the stack's */
        fs_drive_step(&s->drive, &din, &dout);
        command(s, dout.duty, &dout.rect);
        if (record) {
            const long st = cols ? stride : 1;
            double *r = cols ? trace + *rows : trace + (size_t)(*rows) * FS_CH_N;
            row_plant(s, t, s->theta_e, i_ph, &at, din.u_dc, r, st, !cols);
            row_drive(s, s->theta_e, &din, &dout, r, st, !cols);
            ++*rows;
        }
        if (c->lock_stop && dout.lock_lost) {
            s->stopped = FS_STOP_LOSS_OF_LOCK;
            s->stop_time = t;
            return s->stopped;
        }
        if (dout.fault != FS_FAULT_NONE) {   /* the drive halted: as a firmware would, stop (the PWM off) */
            s->stopped = dout.fault == FS_FAULT_POLARITY ? FS_STOP_POLARITY
                       : dout.fault == FS_FAULT_OVERSPEED ? FS_STOP_OVERSPEED
                       : dout.fault == FS_FAULT_START ? FS_STOP_START : FS_STOP_LOSS_OF_LOCK;
            s->stop_time = t;
            return s->stopped;
        }
        int st = advance(s, t);
        if (st != FS_RUN_DONE) return st;
    }
    return FS_RUN_DONE;
}

int fs_sim_run(fs_sim *s, double t_end, double *trace, int max_rows, int *rows)
{
    return fs_sim_run_steps(s, fs_sim_steps(s, t_end), trace, max_rows, rows);
}

int fs_sim_run_steps(fs_sim *s, long long k_end, double *trace, int max_rows, int *rows)
{
    return run(s, k_end, trace, 0, max_rows, rows, 0);
}

int fs_sim_run_cols(fs_sim *s, long long k_end, double *trace, long stride, int max_rows, int *rows)
{
    if (stride < max_rows || stride < 1) return FS_RUN_ERR_STRIDE;
    const int rc = run(s, k_end, trace, stride, max_rows, rows, 1);
    /* rows it wrote, into a trace it had (a refused call leaves *rows as it was) */
    if (rc != FS_RUN_ERR_NULL && *rows > 0) fill_held(s, trace, stride, *rows);
    return rc;
}

int fs_sim_hold(fs_sim *s, int which, double value, double slope)
{
    if (!s || which < 0 || which >= P_N) return -1;
    s->held[which] = 1;
    s->fixed[which] = 1;
    s->fixed_y[which] = value;
    s->fixed_slope[which] = slope;
    return 0;
}

int fs_sim_sample(fs_sim *s, fs_drive_in *in, double *t)
{
    if (!s || !in || !t) return FS_RUN_ERR_NULL;
    if (s->stopped) return s->stopped;
    double i_ph[FS_INV_MAX_LEGS];
    fs_pmsm_at at;
    *t = (double)s->k * s->Tc;
    sample(s, *t, in, i_ph, &at);
    s->sampled = 1;
    return FS_RUN_DONE;
}

int fs_sim_actuate(fs_sim *s, const float *duty, const fs_imc_rect *rect)
{
    if (!s || !duty || (s->imc && !rect)) return FS_RUN_ERR_NULL;
    if (s->stopped) return s->stopped;
    if (!s->sampled) return FS_RUN_ERR_ORDER;
    s->sampled = 0;
    command(s, duty, rect);
    return advance(s, (double)s->k * s->Tc);
}

void fs_sim_plant_row(fs_sim *s, double *row)
{
    if (!s || !row) return;
    const double t = fs_sim_time(s);
    double i_ph[FS_INV_MAX_LEGS];
    fs_pmsm_at at;
    phase_currents_at(s, s->x, i_ph, &at);
    double u_dc = s->cfg.inverter.u_dc;
    if (!s->imc && (s->prof[P_U_DC_SCALE].n > 0 || s->held[P_U_DC_SCALE]))
        u_dc = s->u_dc0 * prof(s, P_U_DC_SCALE, t, NULL);
    if (s->imc && s->k > 0) u_dc = (float)(s->g_int[1] / s->Tc);   /* as the drive samples it */
    row_plant(s, t, wrap_pi(s->cfg.plant.pole_pairs * s->x[FS_X_THETA_M]), i_ph, &at, (float)u_dc, row, 1, 1);
}

void fs_sim_dc_link(fs_sim *s, double *u_dc, double *i_dc, double *p_dc)
{
    double u = NAN, p = NAN;
    if (s && s->k > 0) {
        double i_ph[FS_INV_MAX_LEGS];
        phase_currents(s, s->x, i_ph, NULL, NULL);
        u = s->imc ? s->g_int[1] / s->Tc : s->cfg.inverter.u_dc;
        p = s->losses ? (s->e_dc - s->e_dc0) / s->Tc   /* the source's meter: devices, commutations */
                      : (s->x[FS_X_E_IN] - s->e_in0) / s->Tc + 0.5 * (s->p_cond0 + conduction_loss(s, i_ph));
    }
    if (u_dc) *u_dc = u;
    if (p_dc) *p_dc = p;
    if (i_dc) *i_dc = p / u;
}
