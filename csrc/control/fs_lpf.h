/* First-order low-pass filter with an adaptive cutoff, for a 2-vector.
 *   y' = w_c (x - y),  discretised by backward Euler (stable for any w_c).
 * Its phase lag at the cutoff is pi/4, whatever the cutoff (yang2022,
 * sec. 2: the cutoff follows the estimated speed). */
#ifndef FS_LPF_H
#define FS_LPF_H

#include "fs_transforms.h"
#include "fs_types.h"

typedef struct {
    float Ts;        /* s */
    float w_c_min;   /* floor on the cutoff, rad/s (keeps it defined at standstill) */
} fs_lpf_config;

typedef struct {
    fs_lpf_config cfg;
    fs_ab y;
} fs_lpf;

fs_status fs_lpf_init(fs_lpf *f, const fs_lpf_config *cfg);
void fs_lpf_reset(fs_lpf *f);
/* One step with cutoff |w_c| (floored at w_c_min); returns the output. */
fs_ab fs_lpf_step(fs_lpf *f, fs_ab x, float w_c);
/* The step's gain g = w Ts / (1 + w Ts) at that cutoff, and the step with
 * it: for a caller that needs the gain as well (the SMO's lag
 * compensation), formed once. */
float fs_lpf_gain(const fs_lpf *f, float w_c);
fs_ab fs_lpf_step_gain(fs_lpf *f, fs_ab x, float g);

#endif /* FS_LPF_H */
