/* Magnet polarity by a small, bounded motion (beyond the papers): for a
 * salient machine whose d axis shows no saturation asymmetry (linear
 * magnetics, or too little at a pulse the rotor tolerates), where
 * fs_polarity's d-current pulses cannot decide.
 *
 * An injection estimator locks onto the d axis or onto its opposite (the
 * saliency repeats every pi), and follows the rotor's motion either way: a
 * pi-off estimate turns as the rotor does. A q current in the estimated
 * frame makes torque (phases/2) p psi_f i_q on a right estimate and the
 * opposite on a pi-off one (the reluctance torque is nil with i_d = 0): the
 * way the rotor turns under a push tells north from south.
 *
 * The turn is read with no current flowing, before and after: the estimate
 * moves with the current by itself (the fundamental's leak into the
 * carrier's filters, the inverter's voltage error on the carrier: on the
 * zoo's linear machines by 2..4 el.deg at the push's 15 A, the wrong way as
 * often as not), more than the few degrees the push turns the rotor. So the
 * push is a doublet that leaves the rotor at rest: its first half
 * accelerates it, its second half, the opposite current, stops it (against
 * the motion on either estimate); then the
 * current is off while the filters and the observer settle (t_settle), and
 * the estimate's turn since before the doublet decides. The doublet is one
 * period of a sine, i_now sin(pi t / t_push) over 2 t_push: it turns the
 * rotor by p T_peak (2 t_push)^2 / (2 pi J) and leaves it at rest, and its
 * current has no step, which the carrier's filters and the observer would
 * answer by turning the estimate by tens of degrees for tens of ms (zoo
 * machine 71: +18 el.deg after a square doublet's end, the rotor at rest).
 *
 * Sequence (the caller commands i_d = 0 and the returned i_q on the
 * estimated d axis, and passes the injection's angle every step):
 *   LOCK    t_lock with no current: the estimator settles on the axis; over
 *           the second half the estimate's spread (max - min about its
 *           value at the half) and its mean speed (the slope of a
 *           least-squares line) are taken; where they refuse (below), the
 *           lock runs again,
 *           FS_MOTION_LOCKS times in all (an estimate that started far off
 *           the axis may still be pulling in);
 *   PUSH    the doublet, 2 t_push;
 *   SETTLE  no current for t_settle, then the turn since the lock's end
 *           (where the estimate still turns by the threshold over the
 *           settling's second half, another settling, FS_MOTION_LOCKS in
 *           all, then refused, at once where it has turned beyond theta_max:
 *           an observer still catching up with the rotor settles, a load
 *           that moves the rotor does not): beyond the
 *           threshold max(theta_dec, 2 x the lock's spread),
 *           DONE with flip = (it turned against the push): the estimate
 *           points at the south pole; else another doublet 1.5 times
 *           larger (up to i_push_max; the turns add up), then UNDETERMINED.
 *   DONE    the caller adds pi to the estimate if flip.
 * It refuses (UNDETERMINED) rather than guess: a threshold above theta_max
 * (the estimate too noisy to decide within the motion allowed), a rotor
 * turning before the doublet (its mean speed over the lock's second half
 * would turn it by the threshold within a doublet and its settling, which
 * the doublet's design turn, twice theta_dec, still outweighs: a load moves
 * it, and the turn's direction would not be the push's), or
 * no turn of the threshold at the largest doublet (the rotor held:
 * stiction, a brake).
 * The design (fullspeed.design.start) sizes the push from J, psi_f and the
 * load for a turn of 1.5 theta_dec, and bounds the rotor's motion.
 * The caller keeps the observers' torque feed-forward as it was before the
 * test (fs_drive_start.c): it is right on one estimate and wrong by twice
 * the push on the other, so the observers take the push as an unknown load
 * and follow the rotor's turn in its own direction.
 */
#ifndef FS_MOTION_TEST_H
#define FS_MOTION_TEST_H

#include "fs_types.h"

typedef enum {
    FS_MOTION_LOCK = 0,
    FS_MOTION_PUSH = 1,          /* the doublet */
    FS_MOTION_SETTLE = 2,
    FS_MOTION_DONE = 3,
    FS_MOTION_UNDETERMINED = 4   /* no decision: polarity unknown */
} fs_motion_test_stage;

/* the locks run before the test refuses a noisy or turning estimate, and
 * the settlings after a doublet before it refuses a turning one */
enum { FS_MOTION_LOCKS = 3 };

typedef struct {
    float Ts;          /* sampling period, s */
    float i_push;      /* the doublet's peak q current, A (> 0) */
    float i_push_max;  /* the largest of the retries, A (0: i_push, no retry; else >= i_push) */
    float t_lock;      /* settling of the estimator, s (>= 8 Ts) */
    float t_push;      /* each half of the doublet, s (>= Ts) */
    float t_settle;    /* no current before the turn is read, s (>= Ts; t_lock + 2 t_push + t_settle < 1e3 s and 1e9 Ts) */
    float theta_dec;   /* the estimate's turn that decides, el. rad (> 0, < pi/2) */
    float theta_max;   /* the largest threshold accepted, el. rad (0: 4 theta_dec; else >= theta_dec, < pi/2) */
} fs_motion_test_config;

typedef struct {
    fs_motion_test_config cfg;
    int n_lock, n_push, n_settle;   /* steps */
    int stage;             /* fs_motion_test_stage */
    int k;                 /* steps into the stage */
    int attempts;          /* doublets run so far */
    int locks;             /* locks that refused so far */
    int settles;           /* settlings of this doublet that found the estimate still turning */
    float i_now;           /* the doublet of this attempt, A */
    float theta_half;      /* the estimate at the window's start (the second half of a lock or of the settling), el. rad */
    float lo, hi;          /* its range about theta_half over the window, el. rad */
    float sx, sy, sxx, sxy;   /* sums of the least-squares line through the window's estimate (steps, el. rad) */
    int n_win;             /* samples in the window */
    float threshold;       /* el. rad */
    float theta_ref;       /* the estimate at the lock's end */
    float turn;            /* the estimate's turn from there at the last reading, el. rad */
    bool moved;            /* UNDETERMINED because the rotor turned before the doublet */
    bool flip;             /* result, valid in DONE */
} fs_motion_test;

fs_status fs_motion_test_init(fs_motion_test *m, const fs_motion_test_config *cfg);
void fs_motion_test_reset(fs_motion_test *m);
/* One step with the injection's angle estimate; returns the q-current
 * reference for the next period (0 once DONE or UNDETERMINED). */
float fs_motion_test_step(fs_motion_test *m, float theta);

#endif /* FS_MOTION_TEST_H */
