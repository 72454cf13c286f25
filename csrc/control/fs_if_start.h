/* The current-vector (I/f) start into the back-EMF observer, with active
 * damping (beyond the papers): for a machine without the saliency an
 * injection estimator needs (a surface-PM machine), and for the speeds below
 * where the back-EMF observer is trusted.
 *
 * A current of i_start on the d axis of a frame that turns at w and
 * accelerates at a_start towards the target speed (the loops' reference,
 * held within +-w_handover): the rotor's d axis lags the current by the load
 * angle delta at which (phases/2) p psi_f i_start sin(delta) carries the
 * load and the acceleration; from standstill the current first aligns the
 * rotor (it turns by up to pi). The frame's caller (fs_drive_start.c) hands
 * the loops to the observer at w_handover.
 *
 * A rotor held by a current is a pendulum: J/p delta'' = -(phases/2) p
 * psi_f i_start cos(delta0) delta + ..., natural frequency w_swing, and with
 * the current controlled nothing damps it but friction (the zoo's machines:
 * damping ratios below 0.001; a stator fed by a voltage instead would add
 * at most psi_f^2 / R of it, 0.01..0.4 there). Undamped, an alignment from
 * pi off swings through pi forever and the first load or acceleration pulls
 * the rotor out. So the frame's current gets a damping part: the rotor's
 * EMF in the frame, e = w_r psi_f (sin delta, cos delta), less the one the
 * frame's own speed would make along it, |w| psi_f e / |e| (w_r = w leaves
 * nothing, whatever delta; along q instead where the rotor turns against
 * the frame), through a band-pass about w_swing (a high-pass at w_swing / 4
 * takes out what does not swing: the slow drift of the load angle, the
 * voltage errors of the dead time and of R_s, which lie along the current;
 * a low-pass at 4 w_swing the noise), over a virtual resistance:
 *   i = (i_start, 0) - BP[e (1 - |w| psi_f / |e|)] / r_damp,
 * whose torque on the rotor, -(phases/2) p psi_f^2 (w_r - w) / r_damp,
 * damps the swing as a stator resistance r_damp would (the design puts its
 * ratio at 0.7 on the swing at i_start). Taking (0, w psi_f) off instead
 * left w psi_f sin(delta) in e_d: while the frame accelerates that ramp
 * passes the high-pass as a steady a psi_f sin(delta) / (w_hp r_damp) off
 * the d current, the one that carries the load (on the zoo's low-saliency
 * machines under half rated load the rotor fell out of step as the ramp
 * began, from a ratio of 0.65 on). The EMF
 * comes from what the drive knows: the realised voltage that acted over
 * the period that ended at this sample, the currents at its ends,
 *   e = u - R_s (i_k + i_k-1) / 2 - L (i_k - i_k-1) / Ts   (stationary frame),
 * turned into the frame at the period's middle (L the mean of L_d and L_q:
 * what a machine without saliency has). The reference's magnitude is held
 * within i_max.
 * The hand-over waits at w_handover for the observer; after t_handover
 * there the start has failed (timed_out): the caller stops.
 */
#ifndef FS_IF_START_H
#define FS_IF_START_H

#include "fs_transforms.h"
#include "fs_types.h"

typedef struct {
    float Ts;           /* sampling period, s */
    float i_start;      /* current on the frame's d axis, A (> 0) */
    float a_start;      /* the frame's acceleration, el. rad/s^2 (> 0) */
    float w_handover;   /* the frame's largest speed, el. rad/s (> 0) */
    float R_s, L, psi_f;  /* the controller's model: ohm, H (> 0), Wb */
    float r_damp;       /* the damping's virtual resistance, ohm (0: no damping) */
    float w_swing;      /* the swing's natural frequency the damping's band is centred on, rad/s (> 0 with r_damp; w_swing Ts <= 0.1) */
    float i_max;        /* the reference's largest magnitude, A (>= i_start) */
    float t_handover;   /* the longest wait at w_handover, s (0: no limit) */
} fs_if_start_config;

typedef struct {
    fs_if_start_config cfg;
    float a_hp, b_lp;        /* the band-pass: exp(-w_swing / 4 Ts), 1 - exp(-4 w_swing Ts) (at most 0.1 / Ts) */
    /* state */
    float theta, w;          /* the frame, el. rad and rad/s */
    fs_ab i_prev;            /* the current at the last step */
    bool primed;             /* i_prev holds a sample */
    fs_dq x_prev, hp, lp;    /* the band-pass: its input before, the high-pass, the low-pass (the damping's EMF) */
    float t_held;            /* s at w_handover */
    bool timed_out;          /* t_held passed t_handover */
} fs_if_start;

fs_status fs_if_start_init(fs_if_start *s, const fs_if_start_config *cfg);
/* The frame at theta, turning at w; the damping and the wait start afresh. */
void fs_if_start_reset(fs_if_start *s, float theta, float w);
/* One step: i_ab sampled now, u_ab the realised voltage over the period that
 * ended now; the frame moves towards w_target (el. rad/s, held within
 * +-w_handover). Returns the current reference in the frame (at the angle
 * s->theta after the step). */
fs_dq fs_if_start_step(fs_if_start *s, float w_target, fs_ab i_ab, fs_ab u_ab);

#endif /* FS_IF_START_H */
