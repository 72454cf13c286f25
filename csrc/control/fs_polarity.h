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
    FS_POLARITY_DONE = 3
} fs_polarity_stage;

typedef struct {
    float Ts;        /* sampling period, s */
    float i_pulse;   /* d-current pulse amplitude, A (> 0) */
    float t_lock;    /* settling of the estimator before the pulses, s (>= 0) */
    float t_pulse;   /* length of each pulse, s (>= 4 Ts; t_lock + t_pulse < 1e3 s and 1e9 Ts) */
} fs_polarity_config;

typedef struct {
    fs_polarity_config cfg;
    int n_lock, n_pulse;   /* steps */
    int stage;             /* fs_polarity_stage */
    int k;                 /* steps into the stage */
    float sum_pos, sum_neg;
    float i_p_pos, i_p_neg;   /* the averages, A */
    bool flip;             /* result, valid in DONE */
} fs_polarity;

fs_status fs_polarity_init(fs_polarity *p, const fs_polarity_config *cfg);
void fs_polarity_reset(fs_polarity *p);
/* One step with the positive carrier amplitude of this sample; returns the
 * d-current reference for the next period (0 once DONE). */
float fs_polarity_step(fs_polarity *p, float i_p);

#endif /* FS_POLARITY_H */
