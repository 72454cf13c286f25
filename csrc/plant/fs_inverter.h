/* Two-level three- or five-phase voltage-source inverter (double), for
 * simulation.
 *
 * The carrier is center-aligned: it falls from its peak (1) to its valley (0)
 * in the first half of a period and rises back in the second. A pole is
 * high while the carrier is below its duty, so every period starts and ends
 * at the peak in the zero vector where the currents are sampled.
 *
 * AVERAGED  the pole voltage is its mean over the period: (d - 1/2) u_dc,
 *           less the mean dead-time error sign(i) t_dead/T_pwm u_dc (when the
 *           pole switches), less the device drop sign(i) u_on + r_on i.
 * SWITCHING each half period is cut at the commanded edges and at the ends of
 *           the dead times; in a dead time both devices are off and a diode
 *           carries the current, so the pole sits on the rail opposite to the
 *           current's sign. Each constant segment is integrated on its own.
 *
 * Devices: ideal but for the drop sign(i) u_on + r_on i of whichever
 * conducts, or (dev.enabled) the module's transistors and diodes
 * (fs_losses.h): on each rail the one the current's sign picks (a diode in
 * the dead time), in the averaged model each rail's for its share of the
 * period. A leg's rail s (1 upper, 0 lower; its share of the period,
 * averaged) and its drop give the converter's meters: the dc link passes
 * u_dc sum s_k i_k, the devices dissipate sum drop_k i_k.
 *
 * The load is star-connected without a neutral wire: a phase voltage is its
 * pole voltage less the mean of the pole voltages (no zero sequence). The
 * output is the stationary voltage of the fundamental plane (alpha, beta)
 * and, for five phases, of the third-harmonic plane (x, y) of the
 * amplitude-invariant vector space decomposition below; x = y = 0 for three
 * phases.
 *
 * Five-phase VSD, phase k = 0..4 at k g, g = 2 pi/5:
 *   alpha = 2/5 sum v_k cos(k g),   beta = 2/5 sum v_k sin(k g),
 *   x     = 2/5 sum v_k cos(3 k g), y    = 2/5 sum v_k sin(3 k g),
 *   zero  = 1/5 sum v_k,
 *   v_k   = alpha cos(k g) + beta sin(k g) + x cos(3 k g) + y sin(3 k g) + zero.
 * A third-harmonic phase quantity cos(3 (theta - k g)) maps to
 * (x, y) = (cos 3 theta, sin 3 theta).
 */
#ifndef FS_INVERTER_H
#define FS_INVERTER_H

#include "../control/fs_types.h"
#include "fs_losses.h"

typedef enum { FS_INV_AVERAGED = 0, FS_INV_SWITCHING = 1 } fs_inverter_kind;

typedef struct {
    int kind;          /* fs_inverter_kind */
    double u_dc;       /* dc-link voltage, V */
    double T_pwm;      /* carrier period, s */
    double t_dead;     /* dead time, s */
    double u_on;       /* device on-state drop, V (its threshold part) */
    double r_on;       /* device on-state resistance, ohm: the drop is sign(i) u_on + r_on i */
    int phases;        /* legs: 3 or 5 (5: five-phase; anything else is taken as 3) */
    fs_device_config dev;   /* enabled: the module's devices instead of u_on, r_on (which must be 0) */
} fs_inverter_config;

/* FS_OK (0), or the status of the first field out of range or not finite:
 * FS_ERR_MODE (kind), FS_ERR_LIMIT (u_dc > 0), FS_ERR_TS (T_pwm > 0),
 * FS_ERR_PARAM (t_dead in [0, T_pwm / 2), u_on, r_on >= 0, phases 3 or 5, a
 * device fs_device_check refuses, or u_on, r_on not 0 with the devices). The
 * functions below take any config; this tells whether it is a sound one. */
fs_status fs_inverter_check(const fs_inverter_config *c);

/* Most legs, and most constant segments of a half period (two cuts per leg
 * plus its ends: 2 FS_INV_MAX_LEGS + 1). */
enum { FS_INV_MAX_LEGS = 5 };
enum { FS_INV_MAX_SEG = 11 };

/* A half period as constant-voltage segments. */
typedef struct {
    int n;
    double dt[FS_INV_MAX_SEG];                    /* segment lengths, s */
    int state[FS_INV_MAX_SEG][FS_INV_MAX_LEGS];   /* per leg: 1 high, 0 low, -1 both off */
} fs_inv_segments;

/* Segments of half period `half` (0: carrier falling, 1: rising); duty and
 * the states have c->phases entries. */
void fs_inverter_segments(const fs_inverter_config *c, const double *duty, int half,
                          fs_inv_segments *seg);
/* Segment n's voltage lasts beyond it through the segments after it that
 * have no leg in dead time and the same states as segment n's with each of
 * its legs in dead time on its diode's rail at phase currents i_ph (a dead
 * time ends on the rail its diode already held the leg to): how many
 * segments from n on have the one voltage, 1 if none after it does. Only
 * an inverter without drops (no devices, u_on = r_on = 0) has a segment's
 * voltage independent of the currents: with drops, 1. */
int fs_inverter_same_voltage(const fs_inverter_config *c, const fs_inv_segments *seg, int n, const double *i_ph);
/* Phase voltages (pole voltage less the mean of the poles) of a segment's
 * switch states given the phase currents (for diodes and device drops);
 * c->phases entries each. */
void fs_inverter_phase_voltages(const fs_inverter_config *c, const int *state, const double *i_ph,
                                double *u_ph);
/* Stationary-frame terminal voltage of a segment's switch states given the
 * phase currents: fundamental plane (alpha, beta) and third-harmonic plane
 * (x, y; 0 for three phases). */
void fs_inverter_voltage(const fs_inverter_config *c, const int *state, const double *i_ph,
                         double *u_alpha, double *u_beta, double *u_x, double *u_y);
/* Averaged model: mean stationary voltage over the period, both planes. */
void fs_inverter_mean_voltage(const fs_inverter_config *c, const double *duty, const double *i_ph,
                              double *u_alpha, double *u_beta, double *u_x, double *u_y);
/* The same for an inverter without dead time, drops or devices, whose mean
 * voltage the currents do not move: fs_inverter_mean_voltage's bits at zero
 * currents, without its dead-time and drop terms (each an exact zero there). */
void fs_inverter_mean_voltage_ideal(const fs_inverter_config *c, const double *duty, double *u_alpha,
                                    double *u_beta, double *u_x, double *u_y);
/* Each leg's rail s (1 upper, 0 lower) and the drop of its conducting
 * devices (signed as its current) in a segment's switch states, or over a
 * period of the averaged model (s its mean: the duty less the dead time's
 * share); c->phases entries each. */
void fs_inverter_legs(const fs_inverter_config *c, const int *state, const double *i_ph, double *s, double *drop);
void fs_inverter_mean_legs(const fs_inverter_config *c, const double *duty, const double *i_ph, double *s,
                           double *drop);
/* The devices' energy (fs_device_commutation, at u_dc) of the legs that
 * leave a definite state (0 or 1) for another between `before` and `after`,
 * at the phase currents then, J (0 without dev.enabled). */
double fs_inverter_commutations(const fs_inverter_config *c, const int *before, const int *after, const double *i_ph);

/* Five-phase VSD of five phase quantities (the zero sequence is dropped),
 * and its inverse with a given zero sequence. */
void fs_inverter_vsd5(const double v[5], double *alpha, double *beta, double *x, double *y);
void fs_inverter_vsd5_inverse(double alpha, double beta, double x, double y, double zero, double v[5]);

#endif /* FS_INVERTER_H */
