/* Magnet polarity detection for a saliency-tracking estimator (yang2022
 * sec. 3 requires it before start-up and leaves the method open).
 *
 * The HF saliency repeats every pi: an injection estimator locks onto the d
 * axis or onto its opposite. The magnet tells them apart by saturation: a
 * d current that adds to the magnet flux saturates the iron and lowers the
 * incremental d inductance, one that opposes it does not. The injection
 * itself measures the inductance: the positive-sequence carrier amplitude
 * I_p of eq. (24) grows as the inductances fall.
 *
 * Sequence (the caller commands i_d_ref on the estimated d axis, i_q = 0,
 * and passes I_p every step):
 *   LOCK   t_lock with i_d = 0: the estimator settles on the axis;
 *   POS    t_pulse with i_d = +i_pulse; I_p averaged over the second half;
 *   NEG    t_pulse with i_d = -i_pulse; the same;
 *   DONE   flip = (I_p at +i_pulse < I_p at -i_pulse): the estimate points
 *          at the south pole; the caller adds pi to it.
 *
 * It decides only with a margin. The relative difference
 *   D = (I_p,pos - I_p,neg) / ((I_p,pos + I_p,neg) / 2)
 * must exceed its threshold, max(d_min, 3 sigma_D), where sigma_D is the
 * noise of D from the spread of the carrier periods' means of I_p within
 * the two averaging windows (correlated over 1 / w_filter: about
 * w_filter T / 2 independent ones in a window T, at most one a period).
 * margin = |D| / threshold; below 1 the pulses
 * run again 1.5 times larger, up to i_pulse_max, and then the stage is
 * UNDETERMINED: the caller must not start sensorless (a machine without
 * d-axis saturation asymmetry, e.g. linear magnetics, always ends there).
 * Nor does it decide on a rotor the pulses spun up: a d current on an
 * estimate a few degrees off the axis makes torque, and a light rotor
 * aligned with the magnet's south pole turns away from the pulse that
 * opposes the magnet (an unstable equilibrium) within 20 ms; the
 * fundamental current of a rotor turning at a fair fraction of the
 * positive-sequence filter's bandwidth enters that filter's band and
 * changes I_p by more than saturation does (a linear machine then shows
 * D of tens of per cent). When the mean estimated speed over a half pulse
 * differs by more than w_max from the half before it in the pair (means,
 * so that the estimate's noise does not count), the stage is UNDETERMINED
 * (moved is set): larger pulses would spin it faster. A rotor held at a
 * speed, or drifting slowly under its load, is measured.
 * The averaging window is a whole number of carrier periods (n_carrier
 * samples each), so that the carrier's ripple in I_p, which does not
 * depend on the pulse's sign, leaves no residue that could decide.
 * The pulses make no torque on an aligned rotor (i_q = 0). What is
 * averaged must have settled in the first half of each pulse: the current
 * loop (1 / bw_current) and the carrier amplitude I_p, which the injection
 * filter follows with its time constant 1 / w_b_p (3.2 ms at the yang2022
 * defaults): t_pulse / 2 several times that (20 ms pulses: 3 time
 * constants). i_pulse must reach saturation: about half the rated current
 * on common machines.
 */
#ifndef FS_POLARITY_H
#define FS_POLARITY_H

#include "fs_types.h"

typedef enum {
    FS_POLARITY_LOCK = 0,
    FS_POLARITY_POS = 1,
    FS_POLARITY_NEG = 2,
    FS_POLARITY_DONE = 3,
    FS_POLARITY_UNDETERMINED = 4   /* no margin at i_pulse_max: polarity unknown */
} fs_polarity_stage;

/* d_min's default: the smallest relative difference of the carrier
 * amplitude taken as the magnet's. 5 %: on the machine zoo (fullspeed.model.zoo)
 * the machines with linear magnetics show up to 2.5 % from effects that are
 * not saturation (the rotor's motion under the pulses, the inverter's
 * voltage error), the saturating ones 7 % and more at half their rated
 * current (yang2022's machine: 17 % at 30 A). */
#define FS_POLARITY_D_MIN 0.05f
/* w_max's default, a fraction of w_filter: a tenth of the filter's band. */
#define FS_POLARITY_W_MAX_PER_FILTER 0.1f

typedef struct {
    float Ts;        /* sampling period, s */
    float i_pulse;   /* d-current pulse amplitude, A (> 0) */
    float t_lock;    /* settling of the estimator before the pulses, s (>= 0) */
    float t_pulse;   /* length of each pulse, s (>= 4 Ts; t_lock + t_pulse < 1e3 s and 1e9 Ts) */
    float i_pulse_max; /* the largest pulse of the retries, A (0: i_pulse, no retry; else >= i_pulse) */
    float d_min;     /* the relative difference's floor (0: FS_POLARITY_D_MIN; else in (0, 1)) */
    float w_filter;  /* the carrier amplitude's filter bandwidth, rad/s (0: samples taken as independent) */
    int n_carrier;   /* samples per carrier period (0 or 1: the window is not rounded) */
    float w_max;     /* the change of the estimated speed that invalidates a pair, el. rad/s (0: w_filter / 10; none without w_filter) */
} fs_polarity_config;

typedef struct {
    fs_polarity_config cfg;
    int n_lock, n_pulse;   /* steps */
    int stage;             /* fs_polarity_stage */
    int k;                 /* steps into the stage */
    int n_avg;             /* samples averaged in each pulse (whole carrier periods) */
    int n_per;             /* samples a period of that window (n_carrier, or 1) */
    float acc;             /* the running carrier period's sum */
    float i_now;           /* the pulse of this attempt, A */
    int attempts;          /* pulse pairs run so far */
    float sum_pos, sum_neg, sq_pos, sq_neg;   /* sums of I_p - ref and its square (ref: the first sample) */
    float ref_pos, ref_neg;
    float i_p_pos, i_p_neg;   /* the averages, A */
    float d;               /* the relative difference D of the last attempt */
    float margin;          /* |D| over its threshold: >= 1 decides */
    float w_peak;          /* the largest change between half pulses' mean speeds in the pair, el. rad/s */
    float w_sum, w_prev;   /* the running half pulse's sum of speeds; the last half's mean */
    int halves;            /* half pulses closed in this pair */
    bool moved;            /* UNDETERMINED because the pulses spun the rotor */
    bool flip;             /* result, valid in DONE */
} fs_polarity;

fs_status fs_polarity_init(fs_polarity *p, const fs_polarity_config *cfg);
void fs_polarity_reset(fs_polarity *p);
/* One step with the positive carrier amplitude of this sample and the
 * estimated electrical speed; returns the d-current reference for the next
 * period (0 once DONE or UNDETERMINED). */
float fs_polarity_step(fs_polarity *p, float i_p, float w);

#endif /* FS_POLARITY_H */
