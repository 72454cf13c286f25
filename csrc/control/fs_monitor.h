/* Lock checks that do not trust the estimator (issue 21): residuals for the
 * loss-of-lock monitor (fs_lock.h) formed from what the drive commands and
 * measures, against the angle and speed the loops use. Each is <= 1 while
 * the loops' angle is within about 75 el.deg of the rotor's and grows past 1
 * when it is not; the drive takes the largest with the estimator's own
 * residuals and feeds it to fs_lock.
 *
 * 1. Back-EMF (at speed). The extended EMF of the voltage model,
 *      e = u - R i - L_d di/dt - w (L_d - L_q) [i_b, -i_a]        (alpha-beta)
 *    equals E_ext j e^{j theta} with E_ext = w psi_f + (L_d - L_q)(w i_d
 *    - di_q/dt); turned into the loops' frame it is E_ext j e^{j(theta -
 *    theta_hat)}: its q component is E_ext cos(angle error). Low-passed there
 *    (p = sgn(w_hat) e_q), it is compared with E_hat = |w_hat| psi_f +
 *    w_hat (L_d - L_q) i_d, what the loops' speed says:
 *      r_dir = 1 + (k_dir E_hat - E_err - p) / (E_hat + E_err)
 *    exceeds 1 when p < k_dir E_hat - E_err. A pi-off estimate gives p =
 *    -E_ext, an estimate that slips or spins against the rotor averages e_q
 *    to about 0. The k_dir term only where E_hat >= 3 E_err (an EMF that
 *    should stand out); below, r_dir > 1 only for an EMF that points
 *    backwards beyond the error bound. E_err bounds the q-axis voltage the model leaves out: the dead time's
 *    (k_dead u_dc), a resistance off by up to 100 % (R |i|), inductances off
 *    by up to 100 % acting through the d current (|w_hat| max(L_d, L_q) |i_d|;
 *    for the q current they turn e along d, not q), and a floor of 1 % of the
 *    dc link.
 *    And an estimate stuck at low speed while the rotor turns fast leaves
 *    a voltage far beyond what its speed asks (the EMF it rotates through
 *    averages out of e in its frame, not out of the magnitude):
 *      r_mag = <|u - R i|> / (k_mag |w_hat| (psi_f + L |i|) + 2 E_err + L <|di/dt|>)
 *    with L = max(L_d, L_q) and <> the low-pass of the magnitude.
 * 2. Mechanics (where the back-EMF is too small to judge: E_hat below
 *    3 E_err). The load the loops' motion implies,
 *      T_L_hat = T_ref - (J/p) dw_hat/dt - (B/p) w_hat   (low-passed twice)
 *    is within what a drive rated T_max can hold while the estimate tracks;
 *    a pi-off estimate reverses the torque the loops command, and their
 *    speed loop, seeing the rotor run the wrong way, saturates it: T_L_hat
 *    then reaches 2 T_ref + T_L, about 2 T_max:
 *      r_mech = <|T_L_hat|> / (k_mech T_max)     (its size low-passed once more)
 * 3. The current loops' error |i_ref - i| low-passed against k_cur i_max:
 *    an estimate that spins against the rotor leaves the loops a rotating
 *    back-EMF they cannot follow.
 *
 * Every low-pass has the time constant tau (the drive: lock_time / 4, as for
 * its other residuals); each starts afresh when the checks are switched on.
 * Float32, no heap.
 */
#ifndef FS_MONITOR_H
#define FS_MONITOR_H

#include "fs_transforms.h"
#include "fs_types.h"

typedef struct {
    float Ts;                 /* s, the loops' period */
    int delay;                /* 0, 1 or 2: the voltage computed at k acts over (k+delay, k+delay+1) sampling periods (2 is taken as 1) */
    float R_s, L_d, L_q, psi_f;   /* the controller's machine */
    int pole_pairs;
    float J, B;               /* kg m^2, N m s (J = 0: no mechanical check) */
    float T_max;              /* N m, the drive's torque limit (0: no mechanical check) */
    float i_max;              /* A, its current limit */
    float k_dead;             /* the dead-time voltage left, per volt of the dc link (t_dead / T_pwm) */
    float tau;                /* s, the low-passes' time constant */
} fs_monitor_config;

typedef struct {
    fs_ab i;                  /* the loops' current, alpha-beta, A (fundamental when injecting) */
    fs_ab u_next;             /* the fundamental voltage just computed (acts after `delay`), V */
    float u_dc;               /* V */
    float theta, w;           /* the loops' angle, rad (at this sample), and electrical speed, rad/s */
    float T_ref;              /* N m, the torque the current reference commands */
    fs_dq i_err;              /* i_ref - i, A, in the loops' frame */
    bool on;                  /* the loops run sensorless: check; else the filters rest */
} fs_monitor_in;

typedef struct {
    fs_monitor_config cfg;
    float b;                  /* the low-passes' step, 1 - exp(-Ts / tau) */
    float E_use;              /* V: below it (E_hat and |e|) the back-EMF is not judged, the mechanics are */
    /* state */
    bool started;             /* the filters hold a value (on since the last reset) */
    int k;                    /* steps since started */
    fs_ab i_prev;             /* the last sample's current */
    fs_ab u_q1, u_q2;         /* the voltages computed 1 and 2 steps ago */
    float e_d, e_q;           /* low-passed EMF in the loops' frame, V */
    float v_mag;              /* low-passed |u - R i|, V */
    float di_mag;             /* low-passed |di/dt|, A/s */
    float w_f, T_f, id_f, i_f;    /* low-passed: speed, torque reference, d current, |i| */
    float ierr_f;             /* low-passed |i_ref - i| */
    /* the last step's residuals (<= 1 on track) */
    float r_dir, r_mag, r_mech, r_cur;
    float E_hat, E_err;       /* V, the last step's expected EMF and error bound */
    float T_L_hat;            /* N m */
    float T_L_abs;            /* N m, |T_L_hat| low-passed: what r_mech compares */
} fs_monitor;

/* The design constants (see above; reasons in fs_monitor.c). */
#define FS_MONITOR_K_DIR 0.25f
#define FS_MONITOR_K_MECH 1.2f
#define FS_MONITOR_K_CUR 0.4f

fs_status fs_monitor_init(fs_monitor *m, const fs_monitor_config *cfg);
void fs_monitor_reset(fs_monitor *m);
/* One step at the loops' rate; returns the largest residual (0 while off). */
float fs_monitor_step(fs_monitor *m, const fs_monitor_in *in);

#endif /* FS_MONITOR_H */
