/* Dead-time compensation on the current predicted at each switching edge
 * (float32, no heap).
 *
 * In a dead time both devices are off and the current's diode sets the
 * pole. With the carrier of fs_inverter.h (a pole rises in the first half
 * period, at (1 - d) T_pwm/2, and falls in the second, at d T_pwm/2 into
 * it), the pole loses t_dead of high time at its rising edge when the
 * current there is positive, and gains t_dead at its falling edge when the
 * current there is negative. The usual compensation takes both signs from
 * the current sampled before the period; near a zero crossing, and under an
 * injected carrier whose ripple crosses zero within the period, that sign is
 * wrong at one edge or both.
 *
 * Here each leg's current is predicted at the middle of each of its dead
 * times in the interval the duties will act in: the sample, plus the
 * carrier's current from the injection voltage that acts until then and
 * over the interval up to the edge, through the mean inductance
 * L = (L_d + L_q)/2 (the fundamental's change over 1.5 periods is left out:
 * it is slow against the carrier's):
 *   i_k(tau) = i_k + (T_to_start u_inj,now + tau u_inj,next)_k / L.
 * Each edge is then compensated by its own sign, ramped linearly to 0 within
 * +-i_band as the usual compensation does:
 *   single update (the interval is a period):
 *     dd = t_dead/T_pwm (pos(i(tau_rise)) - neg(i(tau_fall))),
 *   double update (the interval is half a period, alternately the first
 *   and the second): t_dead/(T_pwm/2) pos(i(tau_rise)) in the first half,
 *     -t_dead/(T_pwm/2) neg(i(tau_fall)) in the second,
 * with pos(i) = clamp(i / i_band, 0, 1), neg(i) = clamp(-i / i_band, 0, 1).
 * With a constant current this is the usual compensation exactly; without a
 * carrier (none acting until the interval, none in it) and with one update a
 * period it is computed as the usual one, each edge's current the sample's
 * (half the work: a drive that stops injecting above a speed, fs_blend.h,
 * spends nothing on it there). The
 * halves are counted from the first step, which is taken at the carrier's
 * peak (as the runner and the PWM unit's interrupt do).
 */
#ifndef FS_DTCOMP_H
#define FS_DTCOMP_H

#include "fs_transforms.h"
#include "fs_types.h"

typedef struct {
    int phases;          /* 3 or 5 */
    float T_pwm;         /* carrier period, s */
    float Ts;            /* control period: T_pwm (single update) or T_pwm / 2 (double) */
    float delay;         /* duties act one period later (1) or at once (0) */
    float t_dead;        /* s, > 0 and < T_pwm / 2 */
    float i_band;        /* A, >= 0: the ramp around zero (0: the sign) */
    float L_d, L_q;      /* H, > 0 */
} fs_dtcomp_config;

typedef struct {
    fs_dtcomp_config cfg;
    float inv_L;         /* 1 / mean inductance */
    float dd;            /* t_dead / T_pwm: the duty a dead time takes from a period */
    int double_update;
    int k;               /* steps taken: the half the next interval is */
    fs_ab u_inj_now;     /* the injection voltage acting until the next update */
} fs_dtcomp;

/* FS_ERR_NULL, FS_ERR_PARAM (phases, delay 0 or 1, t_dead, i_band),
 * FS_ERR_TS (T_pwm > 0, Ts = T_pwm or T_pwm / 2), FS_ERR_LD, FS_ERR_LQ, or FS_OK. */
fs_status fs_dtcomp_init(fs_dtcomp *d, const fs_dtcomp_config *cfg);
void fs_dtcomp_reset(fs_dtcomp *d);
/* One step: the duties (phases of them) computed for the next interval are
 * compensated in place, from the currents i_ph sampled now and the
 * injection voltage u_inj (stationary frame) they carry. */
void fs_dtcomp_step(fs_dtcomp *d, const float i_ph[], fs_ab u_inj, float duty[]);
/* The usual compensation, with no instance (the drive's without
 * dt_predict, and without FS_WITH_DTCOMP): each switching phase's duty
 * (0 < duty < 1: a phase held at a rail has no edge and no dead time)
 * moved by dd = t_dead / T_pwm in the sign of its sampled current, ramped
 * over +-i_band (a sign where i_band is 0). */
void fs_dtcomp_sampled(int phases, const float i_ph[], float dd, float i_band, float duty[]);

#endif /* FS_DTCOMP_H */
