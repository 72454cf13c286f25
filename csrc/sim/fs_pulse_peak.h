/* The polarity pulses' current peak through the drive's current loop, for
 * the design (fullspeed.design.start.pulse_peak): a pulse pair 0 -> +i ->
 * -i -> 0 of n samples each, the loop as fs_drive_init designs it (cc),
 * reading the injection's fundamental where filt is given, on a plant's d
 * axis R, L_plant whose voltage is held within u_max. Simulation side:
 * it is the design's check, run thousands of times per scenario, not a
 * controller. */
#ifndef FS_PULSE_PEAK_H
#define FS_PULSE_PEAK_H

#include "../control/fs_current_ctrl.h"
#include "../control/fs_hfi_filter.h"

typedef struct {
    double Ts;                        /* s: the sampling period */
    int delay;                        /* 1: the voltage lands a sample late (the loop predicts it) */
    double R, L_plant;                /* Ohm, H: the plant's d axis */
    double u_max;                     /* V: the voltage held within +-u_max */
    const fs_hfi_filter_config *filt; /* the SRFFs the loop reads through; NULL: none */
    double w_h;                       /* rad/s: the carrier's frequency (with filt) */
} fs_pulse_peak_config;

/* The largest |i_d| of the pair of i_pulse (A) through the loop designed by
 * cc, n samples each step; INFINITY where the loop or the filter refuses
 * its design or the current diverges (past 4 i_pulse + 1 A). */
double fs_pulse_peak(const fs_pulse_peak_config *cfg, const fs_current_ctrl_config *cc, double i_pulse, int n);

#endif /* FS_PULSE_PEAK_H */
