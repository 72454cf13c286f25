/* Transition between the SMO and the HFI angle (yang2022 sec. 4, Fig. 6).
 *
 * A speed-dependent weight, eq. (28), on the estimated speed |w_hat|
 * (electrical rad/s here):
 *   g_w = 0 for |w_hat| <= w_lower, 1 for |w_hat| >= w_upper,
 *         (|w_hat| - w_lower) / (w_upper - w_lower) between,
 * blends the two angles, eq. (27):
 *   theta_blnd = g_w theta_SMO + (1 - g_w) theta_HFI,
 * computed on the circle as theta_HFI + g_w wrap(theta_SMO - theta_HFI),
 * wrapped: the shorter arc between the two, so that angles on either side
 * of +-pi blend to near +-pi, not to near 0. At g_w = 0 (1) the HFI (SMO)
 * angle is returned as it is and the other is not read.
 *
 * The blended angle is filtered by a motion observer (fs_motion_obs, Fig. 5
 * structure) with the error wrap(theta_blnd - theta_hat); its speed
 * estimate drives g_w (Fig. 6). The weight of a step uses the speed from the
 * step before (the loop would be algebraic otherwise). The paper puts
 * w_lower and w_upper at about 10 % and 20 % of the rated speed.
 *
 * The sampling period is the observer's (obs.Ts): the blend itself does not
 * depend on time.
 *
 * Gate (beyond the paper, fs_blend_step_gated): eq. (28) trusts the SMO by
 * speed alone. A load step at standstill or its release pushes the rotor
 * into the band within tens of ms (motulator's 2.2 kW IPMSM at rated load:
 * to -250 and +250 rpm), before the SMO, idle at standstill, has converged;
 * blending its angle in then swung the estimate (39.5 el.deg, and with a
 * 120/195 rpm band the rotor was lost). While the injection estimate is live,
 * the SMO's weight is multiplied by a trust that drops to 0 whenever the SMO
 * has not converged (fs_smo.h: its residuals settled) and comes back over
 * 4 / w_o once it has (so that a gate opening and closing cannot make the
 * weight chatter through the band). Not gated on the two angles agreeing: on
 * a cross-saturated machine the injection estimate is off by the saliency's
 * turn (15 el.deg at 25 A on yang2022's) and the SMO is the better one.
 * Once the injection has stopped there is nothing else: eq. (28) alone, and
 * the caller should stop the injection only at full trust.
 */
#ifndef FS_BLEND_H
#define FS_BLEND_H

#include "fs_motion_obs.h"
#include "fs_types.h"

typedef struct {
    float w_lower;             /* g_w = 0 at and below, rad/s (el.), >= 0 */
    float w_upper;             /* g_w = 1 at and above, rad/s (el.), > w_lower */
    fs_motion_obs_config obs;  /* the filtering observer (Ts, J, B, p, bandwidth) */
    int gate;                  /* 1: the caller gates the SMO's weight (header, fs_blend_step_gated); 0: eq. (28) alone */
} fs_blend_config;

typedef struct {
    fs_blend_config cfg;
    fs_motion_obs obs;
    float g_w;          /* weight used in the last step */
    float theta_blnd;   /* blended angle of the last step, rad */
    float theta_hat;    /* filtered angle, rad, (-pi, pi] (= obs.theta_hat) */
    float w_hat;        /* electrical speed, rad/s (= obs.w_hat) */
    float trust;        /* the gate's factor on g_w, 0..1 */
    float d_trust;      /* its rise per step, w_o Ts / 4 */
} fs_blend;

/* eq. (28): weight for the speed w (either sign). */
float fs_blend_weight(float w, float w_lower, float w_upper);
/* eq. (27) on the circle: the angle at the fraction g of the shorter arc
 * from theta_hfi to theta_smo, wrapped to (-pi, pi]. */
float fs_blend_angle(float theta_smo, float theta_hfi, float g);

fs_status fs_blend_init(fs_blend *b, const fs_blend_config *cfg);
/* Observer at angle theta and electrical speed w; the weight follows w. */
void fs_blend_reset(fs_blend *b, float theta, float w);
/* The filtering observer set to an estimate the caller trusts (angle,
 * electrical speed, the load torque as fs_motion_obs holds it), its weight
 * and gate kept: above the band, where the back-EMF observer alone is
 * blended, the caller may hand its own tracker's state over each step. */
void fs_blend_follow(fs_blend *b, float theta, float w, float T_d);
/* One step with the two angles sampled now and the torque of the period
 * that just ended (N m). Returns the filtered angle theta_hat. */
float fs_blend_step(fs_blend *b, float theta_smo, float theta_hfi, float T_ff);
/* The same with the gate (header): smo_converged is the SMO's `converged`,
 * hfi_live whether the injection estimate is one to fall back on this step
 * (else the trust is 1): running at its full carrier. One that is fading
 * back in is not: the gate then dropped the SMO for it at the injection's
 * resumption (yang2022 at 280 rpm under rated load: 22.9 el.deg). */
float fs_blend_step_gated(fs_blend *b, float theta_smo, float theta_hfi, float T_ff, bool smo_converged, bool hfi_live);

#endif /* FS_BLEND_H */
