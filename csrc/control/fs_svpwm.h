/* Three-phase space-vector PWM by min-max zero-sequence injection, with
 * minimum-phase-error over-modulation.
 *
 * In the linear range (|u| <= u_dc/sqrt3) the duties realise the reference
 * exactly. Beyond it the reference is scaled down to the hexagon boundary in
 * its own direction, so the realised vector keeps the reference's phase
 * (minimum phase error) and reaches up to 2/3 u_dc at the vertices.
 */
#ifndef FS_SVPWM_H
#define FS_SVPWM_H

#include <stdbool.h>
#include "fs_transforms.h"

/* Duties in [0, 1] for the pole voltages (0 = low rail, 1 = high rail).
 * u_real receives the realised stationary voltage. Returns true if the
 * reference was beyond the hexagon (over-modulation). */
bool fs_svpwm(fs_ab u_ref, float u_dc, float duty[3], fs_ab *u_real);

/* The stationary voltage that duties realise, given u_dc (the inverse). */
fs_ab fs_svpwm_voltage(const float duty[3], float u_dc);

#endif /* FS_SVPWM_H */
