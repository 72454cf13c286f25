/* Closed-loop harness for counting the instructions of fs_drive_step
 * (bench/instructions.py runs it under callgrind).
 *
 * An instruction count is only meaningful if the step runs the paths it runs
 * in a real drive: the loops closed, currents that answer the voltages, an
 * encoder that turns, an observer that has converged. So the drive is closed
 * around a small plant -- dq currents of a linear PMSM driven by the averaged
 * inverter voltage (with the dead-time loss the drive compensates), a rotor
 * with inertia, friction and a constant load torque, a quantised encoder and
 * a little current-sensor noise. The plant is double precision on purpose:
 * it is not the code under test and runs outside the measured function.
 *
 * Usage: step_harness --list
 *        step_harness MODE WARMUP STEPS [--trace] name=value ...
 * The machine and operating point come as name=value (see PARAMS); the
 * Python side reads them from the machine catalog. The drive runs WARMUP
 * steps, then STEPS measured steps; with valgrind/callgrind.h available,
 * instrumentation is switched on only for the measured block. Prints one
 * summary line of name=value pairs, and with --trace each measured step's
 * duties first.
 */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fs_drive.h"

#if !defined(FS_BENCH_NO_CALLGRIND) && defined(__has_include)
#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#define HAVE_CALLGRIND 1
#endif
#endif
#ifndef HAVE_CALLGRIND
#define HAVE_CALLGRIND 0
#define CALLGRIND_START_INSTRUMENTATION
#define CALLGRIND_STOP_INSTRUMENTATION
#endif

static const double PI = 3.14159265358979323846;

typedef struct {
    double Ts, T_pwm, u_dc, t_dead;
    double R_s, L_d, L_q, psi_f, pole_pairs, J, B;
    double i_max, bw_current, bw_speed, bw_pll;
    double smo_bw_pll, smo_w_e_max, smo_margin, smo_w_c_min, smo_w_valid;
    double speed_rpm, T_load, noise_i, encoder_bits;
    double inj_u_h, inj_f_h, blend_lower_rpm, blend_upper_rpm;
} params;

#define P(name) {#name, offsetof(params, name)}
static const struct { const char *name; size_t off; } PARAMS[] = {
    P(Ts), P(T_pwm), P(u_dc), P(t_dead),
    P(R_s), P(L_d), P(L_q), P(psi_f), P(pole_pairs), P(J), P(B),
    P(i_max), P(bw_current), P(bw_speed), P(bw_pll),
    P(smo_bw_pll), P(smo_w_e_max), P(smo_margin), P(smo_w_c_min), P(smo_w_valid),
    P(speed_rpm), P(T_load), P(noise_i), P(encoder_bits),
    P(inj_u_h), P(inj_f_h), P(blend_lower_rpm), P(blend_upper_rpm),
};
#undef P
enum { N_PARAMS = sizeof PARAMS / sizeof PARAMS[0] };

/* Settings every mode shares: speed control, the bench's timing and limits. */
static void setup_common(fs_drive_config *c, const params *p)
{
    c->phases = 3;
    c->mode = FS_MODE_SPEED;
    c->Ts = (float)p->Ts;
    c->T_pwm = (float)p->T_pwm;
    c->delay = 1.0f;
    c->R_s = (float)p->R_s;
    c->L_d = (float)p->L_d;
    c->L_q = (float)p->L_q;
    c->psi_f = (float)p->psi_f;
    c->pole_pairs = (int)p->pole_pairs;
    c->J = (float)p->J;
    c->B = (float)p->B;
    c->i_max = (float)p->i_max;
    /* torque at i_max with i_d = 0: below the MTPA maximum, so reachable */
    c->T_max = (float)(1.5 * p->pole_pairs * p->psi_f * p->i_max);
    c->bw_current = (float)p->bw_current;
    c->bw_speed = (float)p->bw_speed;
    c->bw_pll = (float)p->bw_pll;
    c->t_dead_comp = (float)p->t_dead;
    c->i_dead_band = (float)(0.01 * p->i_max);
    /* flux weakening on, as in a full-range drive (the scenarios' default
     * gain, the cutoff designed by fs_drive_init); it runs every step, idle
     * below base speed */
    c->fw_w_e_max = (float)p->smo_w_e_max;
    c->fw_gain = 50.0f;
}

static void setup_encoder(fs_drive_config *c, const params *p)
{
    setup_common(c, p);
    c->angle_source = FS_ANGLE_ENCODER;
}

static void setup_smo(fs_drive_config *c, const params *p)
{
    setup_common(c, p);
    c->angle_source = FS_ANGLE_SMO;
    /* the speed comes from the observer's PLL: keep its lag small at the
     * speed loop's crossover (as the scenarios do) */
    c->bw_speed = (float)fmin(p->bw_speed, p->smo_bw_pll / 6.0);
    c->smo.w_e_max = (float)p->smo_w_e_max;
    c->smo.i_max = (float)p->i_max;
    c->smo.margin = (float)p->smo_margin;
    c->smo.w_c_min = (float)p->smo_w_c_min;
    c->smo.bw_pll = (float)p->smo_bw_pll;
    c->smo.w_valid = (float)p->smo_w_valid;
    c->smo.lag = FS_SMO_LAG_EXACT;
}

/* Rotating HF injection (yang2022 sec. 3) with the machine's carrier and the
 * estimator's default filter and observer bandwidths (fs_hfi.h). */
static void setup_hfi(fs_drive_config *c, const params *p)
{
    setup_common(c, p);
    c->angle_source = FS_ANGLE_HFI;
    c->hfi.u_h = (float)p->inj_u_h;
    c->hfi.w_h = (float)(2.0 * PI * p->inj_f_h);
}

/* The blend of both (yang2022 sec. 4): the SMO, the injection and the
 * filtering observer all run in the band, the injection stopping at 1.2 x
 * the upper speed (the scenarios' default). */
static void setup_blend(fs_drive_config *c, const params *p)
{
    setup_smo(c, p);
    fs_smo_config smo = c->smo;
    float bw_speed = c->bw_speed;
    setup_hfi(c, p);
    c->angle_source = FS_ANGLE_BLEND;
    c->smo = smo;
    c->bw_speed = bw_speed;
    const double rpm_e = 2.0 * PI / 60.0 * p->pole_pairs;
    c->blend.w_lower = (float)(rpm_e * p->blend_lower_rpm);
    c->blend.w_upper = (float)(rpm_e * p->blend_upper_rpm);
    c->w_inject_max = (float)(1.2 * rpm_e * p->blend_upper_rpm);
}

/* Square-wave injection (yu2022) with the filterless processing and the
 * optimized sequence: the carrier at a quarter of the sampling rate (four
 * samples per period), the machine's injection amplitude, the PLL at a
 * two-hundredth of the carrier frequency (yu2022's 57.5 rad/s at 2 kHz)
 * and the speed loop at half of that (as the scenarios do). */
static void setup_square(fs_drive_config *c, const params *p)
{
    setup_common(c, p);
    c->angle_source = FS_ANGLE_SWVI;
    c->swvi.u_h = (float)p->inj_u_h;
    c->swvi.bandwidth = (float)(2.0 * PI / (4.0 * p->Ts) / 200.0);
    c->swvi.sequence = FS_SWVI_OPTIMIZED;
    /* the speed is the PLL's PI output, whose zero keeps its lag small up
     * to about half its bandwidth (yu2022: 31 against 57.5 rad/s) */
    c->bw_speed = (float)fmin(p->bw_speed, c->swvi.bandwidth / 2.0);
}

/* The modes this harness can run; bench/instructions.py lists the ones it
 * wants and reports any not here as "not built yet". A new mode is one entry
 * (and its setup function). sensorless: the loops switch to the estimator
 * halfway through the warm-up, as a real drive hands over once converged. */
static const struct {
    const char *name;
    void (*setup)(fs_drive_config *, const params *);
    int sensorless;
    double speed_rpm;   /* the operating point's speed (0: speed_rpm of the params) */
} MODES[] = {
    {"encoder", setup_encoder, 0, 0.0},
    {"smo", setup_smo, 1, 0.0},
    /* injection at low speed; blended inside its band, where every part runs */
    {"hfi-rotating", setup_hfi, 1, 100.0},
    {"blended", setup_blend, 1, 200.0},
    {"hfi-square", setup_square, 1, 100.0},
};
enum { N_MODES = sizeof MODES / sizeof MODES[0] };

/* ---- the plant -------------------------------------------------------- */

typedef struct {
    double i_d, i_q;     /* rotor frame, A */
    double theta_m, w_m; /* mechanical angle (unwrapped) and speed */
    unsigned rng;
} plant;

static double wrap_pi(double x)
{
    x = fmod(x, 2.0 * PI);
    if (x > PI) x -= 2.0 * PI;
    if (x <= -PI) x += 2.0 * PI;
    return x;
}

/* Deterministic noise, roughly normal with the given standard deviation
 * (sum of four uniforms): runs are reproducible, counts too. */
static double noise(plant *pl, double sigma)
{
    double s = 0.0;
    for (int k = 0; k < 4; ++k) {
        pl->rng ^= pl->rng << 13;
        pl->rng ^= pl->rng >> 17;
        pl->rng ^= pl->rng << 5;
        s += (double)pl->rng / 4294967296.0 - 0.5;
    }
    return s * sigma * sqrt(3.0);
}

/* Phase currents (amplitude-invariant inverse Park and Clarke). */
static void phase_currents(const plant *pl, double c, double s, double i_abc[3])
{
    double i_al = pl->i_d * c - pl->i_q * s, i_be = pl->i_d * s + pl->i_q * c;
    i_abc[0] = i_al;
    i_abc[1] = -0.5 * i_al + 0.5 * sqrt(3.0) * i_be;
    i_abc[2] = -0.5 * i_al - 0.5 * sqrt(3.0) * i_be;
}

/* One control period with the duties held, in substeps (explicit Euler is
 * accurate here: the substep is far below L/R and 1/w_e). */
static void plant_advance(plant *pl, const params *p, const float duty[3])
{
    enum { SUB = 4 };
    const double h = p->Ts / SUB, pp = p->pole_pairs;
    for (int s = 0; s < SUB; ++s) {
        double th = pp * pl->theta_m, c = cos(th), sn = sin(th), w_e = pp * pl->w_m;
        double i_abc[3], v[3];
        phase_currents(pl, c, sn, i_abc);
        for (int k = 0; k < 3; ++k) {
            /* averaged pole voltage, less the dead-time loss (sign of the current) */
            double loss = (i_abc[k] > 0.0) - (i_abc[k] < 0.0);
            v[k] = p->u_dc * (duty[k] - loss * p->t_dead / p->T_pwm);
        }
        double u_al = (2.0 * v[0] - v[1] - v[2]) / 3.0, u_be = (v[1] - v[2]) / sqrt(3.0);
        double u_d = u_al * c + u_be * sn, u_q = -u_al * sn + u_be * c;
        double di_d = (u_d - p->R_s * pl->i_d + w_e * p->L_q * pl->i_q) / p->L_d;
        double di_q = (u_q - p->R_s * pl->i_q - w_e * (p->L_d * pl->i_d + p->psi_f)) / p->L_q;
        double T_e = 1.5 * pp * (p->psi_f + (p->L_d - p->L_q) * pl->i_d) * pl->i_q;
        double dw = (T_e - p->B * pl->w_m - p->T_load) / p->J;
        pl->i_d += h * di_d;
        pl->i_q += h * di_q;
        pl->theta_m += h * pl->w_m;
        pl->w_m += h * dw;
    }
}

/* ---- the loop --------------------------------------------------------- */

typedef struct {
    double speed_err_max;  /* rpm, measured block */
    double angle_err_max;  /* el. deg between the angle the loops use and the rotor's */
    double i_q_sum;
    double duty_min, duty_max;
    int finite, valid_all;
} stats;

static int run(int mode, long warmup, long steps, int trace, const params *p)
{
    fs_drive_config cfg = {0};
    MODES[mode].setup(&cfg, p);
    fs_drive drv;
    fs_status st = fs_drive_init(&drv, &cfg);
    if (st != FS_OK) {
        fprintf(stderr, "step_harness: fs_drive_init: %s\n", fs_status_str(st));
        return 2;
    }
    const double speed_rpm = MODES[mode].speed_rpm > 0.0 ? MODES[mode].speed_rpm : p->speed_rpm;
    const double w_ref = speed_rpm * 2.0 * PI / 60.0;
    const double counts = ldexp(1.0, (int)p->encoder_bits);
    plant pl = {0.0, 0.0, 0.3, w_ref, 0x2545F491u};  /* turning at the reference speed */
    float duty_held[3] = {0.5f, 0.5f, 0.5f};
    stats s = {0.0, 0.0, 0.0, 1.0, 0.0, 1, 1};

    for (long n = 0; n < warmup + steps; ++n) {
        int measured = n >= warmup;
        if (n == warmup) CALLGRIND_START_INSTRUMENTATION;
        fs_drive_in in = {0};
        double th = p->pole_pairs * pl.theta_m, i_abc[3];
        phase_currents(&pl, cos(th), sin(th), i_abc);
        for (int k = 0; k < 3; ++k) in.i_ph[k] = (float)(i_abc[k] + noise(&pl, p->noise_i));
        in.u_dc = (float)p->u_dc;
        double rev = pl.theta_m / (2.0 * PI);
        in.theta_m_enc = (float)(2.0 * PI * (floor((rev - floor(rev)) * counts) / counts));
        in.w_m_ref = (float)w_ref;
        in.sensorless = MODES[mode].sensorless && n >= warmup / 2;
        fs_drive_out out;
        fs_drive_step(&drv, &in, &out);
        /* duties computed now act from the next update instant (delay = 1) */
        plant_advance(&pl, p, duty_held);
        memcpy(duty_held, out.duty, sizeof duty_held);
        if (!measured) continue;
        if (trace) printf("%.9g %.9g %.9g\n", out.duty[0], out.duty[1], out.duty[2]);
        for (int k = 0; k < 3; ++k) {
            s.finite &= isfinite(out.duty[k]);
            s.duty_min = fmin(s.duty_min, out.duty[k]);
            s.duty_max = fmax(s.duty_max, out.duty[k]);
        }
        s.speed_err_max = fmax(s.speed_err_max, fabs(pl.w_m - w_ref) * 60.0 / (2.0 * PI));
        double th_true = wrap_pi(p->pole_pairs * pl.theta_m);
        s.angle_err_max = fmax(s.angle_err_max, fabs(wrap_pi(th_true - out.theta_e)) * 180.0 / PI);
        s.i_q_sum += out.i_q;
        s.valid_all &= out.est_valid;
    }
    CALLGRIND_STOP_INSTRUMENTATION;
    printf("mode=%s speed_rpm=%.6g warmup=%ld steps=%ld callgrind=%d finite=%d duty_min=%.6g duty_max=%.6g "
           "speed_err_max_rpm=%.6g angle_err_max_deg=%.6g i_q_mean=%.6g est_valid=%d\n",
           MODES[mode].name, speed_rpm, warmup, steps, HAVE_CALLGRIND, s.finite, s.duty_min, s.duty_max,
           s.speed_err_max, s.angle_err_max, steps > 0 ? s.i_q_sum / (double)steps : 0.0, s.valid_all);
    return 0;
}

static int usage(void)
{
    fprintf(stderr, "usage: step_harness --list | MODE WARMUP STEPS [--trace] name=value ...\n");
    return 2;
}

int main(int argc, char **argv)
{
    if (argc == 2 && strcmp(argv[1], "--list") == 0) {
        for (int m = 0; m < N_MODES; ++m) printf("%s\n", MODES[m].name);
        return 0;
    }
    if (argc < 4) return usage();
    int mode = -1;
    for (int m = 0; m < N_MODES; ++m)
        if (strcmp(argv[1], MODES[m].name) == 0) mode = m;
    if (mode < 0) {
        fprintf(stderr, "step_harness: unknown mode '%s' (see --list)\n", argv[1]);
        return 2;
    }
    char *end;
    long warmup = strtol(argv[2], &end, 10);
    long steps = *end ? -1 : strtol(argv[3], &end, 10);
    if (*end || warmup < 0 || steps < 0) return usage();

    params p;
    int seen[N_PARAMS] = {0};
    int trace = 0;
    for (int a = 4; a < argc; ++a) {
        if (strcmp(argv[a], "--trace") == 0) {
            trace = 1;
            continue;
        }
        const char *eq = strchr(argv[a], '=');
        int k = 0;
        while (eq && k < N_PARAMS &&
               !(strlen(PARAMS[k].name) == (size_t)(eq - argv[a]) &&
                 strncmp(PARAMS[k].name, argv[a], (size_t)(eq - argv[a])) == 0))
            ++k;
        if (!eq || k == N_PARAMS) {
            fprintf(stderr, "step_harness: unknown argument '%s'\n", argv[a]);
            return 2;
        }
        double v = strtod(eq + 1, &end);
        if (*end || eq[1] == '\0') {
            fprintf(stderr, "step_harness: '%s' is not a number\n", argv[a]);
            return 2;
        }
        *(double *)((char *)&p + PARAMS[k].off) = v;
        seen[k] = 1;
    }
    for (int k = 0; k < N_PARAMS; ++k) {
        if (!seen[k]) {
            fprintf(stderr, "step_harness: missing parameter %s=...\n", PARAMS[k].name);
            return 2;
        }
    }
    return run(mode, warmup, steps, trace, &p);
}
