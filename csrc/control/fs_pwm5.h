/* Nearest-four-vector space-vector PWM (NFV-PWM) for a two-level five-phase
 * inverter (yu2022), as its carrier-based equivalent, with minimum-phase-error
 * over-modulation.
 *
 * The 32 switching states project (fs_vsd.h, pole voltages s_k u_dc) onto the
 * alpha-beta plane as 2 zero vectors and three decagons of 10: large
 * (0.6472 u_dc = 0.8 cos(pi/5) u_dc), medium (0.4 u_dc) and small
 * (0.2472 u_dc = 0.8 cos(2 pi/5) u_dc), large and medium ones at multiples of
 * 36 degrees. A large vector maps to a small x-y vector and a medium one to a
 * medium x-y vector pointing the other way, so dwelling on an aligned large
 * and medium pair in the ratio 2 cos(pi/5) = 1.618 cancels the x-y (third
 * harmonic) voltage. NFV-PWM uses, in each 36-degree sector, the two large and
 * the two medium vectors at its edges, with zero vectors at both ends.
 *
 * Carrier form: the phase references v_k of (u_ref, xy = 0) plus the min-max
 * zero sequence, duty_k = 1/2 + (v_k - (max v + min v)/2) / u_dc. On a
 * center-aligned carrier the legs switch in the order of their duties, which
 * visits exactly those four vectors with those dwell times (test_pwm5.c).
 *
 * Linear range |u_ref| <= u_dc / (2 cos(pi/10)) = 0.5257 u_dc, the circle
 * inscribed in the decagon of references reachable with xy = 0. Beyond it the
 * reference is scaled down to that circle in its own direction (minimum phase
 * error).
 */
#ifndef FS_PWM5_H
#define FS_PWM5_H

#include <stdbool.h>
#include "fs_transforms.h"

/* Duties in [0, 1] (fraction of the period each leg is high) for an
 * alpha-beta reference u_ref (V, amplitude-invariant), x-y reference zero.
 * u_real (may be NULL) receives the mean alpha-beta voltage the duties apply
 * to a star-connected load. Returns true if the reference was beyond the
 * linear range and was scaled down; u_dc <= 0 or a non-finite input gives
 * duties 0.5, u_real = 0 and true. */
bool fs_pwm5(fs_ab u_ref, float u_dc, float duty[5], fs_ab *u_real);

/* The mean alpha-beta voltage that duties apply to a star-connected load. */
fs_ab fs_pwm5_voltage(const float duty[5], float u_dc);

#endif /* FS_PWM5_H */
