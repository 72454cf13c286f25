/* Cross-saturation compensation: the lead delta(i_q) of the HF saliency axis.
 *
 * On a cross-saturated machine the HF saliency axis, which injection-based
 * estimators lock on, lies at theta_r + delta(i_q) (yu2022 eqs. (19)-(21):
 * delta = -phi_dq / 2). Knowing delta, an estimator takes it out. delta is
 * given either as a table measured offline (e.g. with the encoder in the
 * loop, `fullspeed calibrate`) on an even grid i_q0 + k di_q, k < n,
 * interpolated linearly and held at its ends, or, when n = 0, as a cubic
 *   delta = poly[0] + poly[1] i_q + poly[2] i_q^2 + poly[3] i_q^3
 * (yu2022 eq. (22) is such a fit, of the error theta_r - theta_hat = -delta).
 * All zero: no compensation.
 */
#ifndef FS_XCOMP_H
#define FS_XCOMP_H

#include "fs_types.h"

enum { FS_XCOMP_MAX = 33 };

typedef struct {
    int n;                     /* table points: 0 (the polynomial) or 2..FS_XCOMP_MAX */
    float i_q0, di_q;          /* grid: first current, step (> 0), A */
    float delta[FS_XCOMP_MAX]; /* lead of the saliency axis, theta_hat - theta_r, rad (|.| < pi/2) */
    float poly[4];             /* rad, rad/A, rad/A^2, rad/A^3 (n = 0) */
} fs_xcomp_config;

/* FS_OK, or FS_ERR_PARAM for a table or polynomial out of range. */
fs_status fs_xcomp_check(const fs_xcomp_config *c);
/* A table or a non-zero polynomial is given. */
bool fs_xcomp_active(const fs_xcomp_config *c);
/* delta(i_q), rad: 0 for a non-finite i_q, a NULL config or a table that
 * fs_xcomp_check refuses (n above FS_XCOMP_MAX, a step not > 0); the
 * polynomial's value is held within +-pi/2. */
float fs_xcomp_eval(const fs_xcomp_config *c, float i_q);

#endif /* FS_XCOMP_H */
