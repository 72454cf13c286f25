#include "fs_pulse_peak.h"

#include <math.h>

double fs_pulse_peak(const fs_pulse_peak_config *cfg, const fs_current_ctrl_config *cc, double i_pulse, int n)
{
    fs_current_ctrl ctrl;
    fs_hfi_filter filt;
    if (fs_current_ctrl_init(&ctrl, cc) != FS_OK) return INFINITY;
    if (cfg->filt && fs_hfi_filter_init(&filt, cfg->filt) != FS_OK) return INFINITY;
    const double two_pi = 6.28318530717958647692;   /* 2 pi in double */
    const double dth = cfg->w_h * cfg->Ts;
    /* the plant's d axis over one sample, exact for a held voltage */
    const double a = exp(-cfg->R * cfg->Ts / cfg->L_plant);
    const double b = (cfg->R > 0.0 && a < 1.0) ? (1.0 - a) / cfg->R : cfg->Ts / cfg->L_plant;
    const double targets[3] = {i_pulse, -i_pulse, 0.0};
    double i = 0.0, u_prev = 0.0, peak = 0.0, th_h = 0.0;
    fs_dq ref = {0.0f, 0.0f}, meas = {0.0f, 0.0f}, real = {0.0f, 0.0f};
    for (int s = 0; s < 3; ++s) {
        ref.d = (float)targets[s];
        for (int k = 0; k < n; ++k) {
            meas.d = (float)i;
            if (cfg->filt) {   /* the loop reads the fundamental the SRFFs leave */
                fs_ab i_ab = {(float)i, 0.0f}, i_f;
                fs_hfi_filter_step(&filt, i_ab, (float)th_h, 0.0f, &i_f, 0);
                meas.d = i_f.alpha;
                th_h = remainder(th_h + dth, two_pi);
            }
            const double u = fs_current_ctrl_step(&ctrl, ref, meas, 0.0f).d;
            real.d = (float)fmin(fmax(u, -cfg->u_max), cfg->u_max);
            fs_current_ctrl_update(&ctrl, real);
            i = a * i + b * (cfg->delay ? u_prev : (double)real.d);
            u_prev = real.d;
            peak = fmax(peak, fabs(i));
            if (peak > 4.0 * i_pulse + 1.0) return INFINITY;   /* diverging */
        }
    }
    return peak;
}
