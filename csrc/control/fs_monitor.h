/* Lock checks that do not trust the estimator (issue 21): residuals for the
 * loss-of-lock monitor (fs_lock.h) formed from what the drive commands and
 * measures, against the angle and speed the loops use. Each is <= 1 while
 * the loops' angle is within about 75 el.deg of the rotor's and grows past 1
 * when it is not; the drive takes the largest with the estimator's own
 * residuals and feeds it to fs_lock. One check is an event instead (4.):
 * it latches fs_lock at once.
 *
 * 1. Back-EMF direction (at speed). The extended EMF of the voltage model,
 *      e = u - R i - L_d di/dt - w (L_d - L_q) [i_b, -i_a]        (alpha-beta)
 *    equals E_ext j e^{j theta} with E_ext = w psi_f + (L_d - L_q)(w i_d
 *    - di_q/dt); turned into the loops' frame it is E_ext j e^{j(theta -
 *    theta_hat)}: its q component is E_ext cos(angle error). Low-passed there
 *    (p = sgn(w_hat) e_q), it is compared with E_hat = |w_hat| psi_f +
 *    w_hat (L_d - L_q) i_d, what the loops' speed says:
 *      r_dir = 1 + (k_dir E_hat - E_err - p) / (E_hat + E_err)
 *    exceeds 1 when p < k_dir E_hat - E_err. The q current's rate is taken
 *    out of p first, p = sgn(w_hat) (e_q + (L_d - L_q) di_q/dt) (the same
 *    low-pass), and its size, |L_d - L_q| |di_q/dt|, added to E_err: the
 *    part of E_ext that does not turn with the speed, which at standstill
 *    under a rising load read as a backward EMF (the Baldor PM-SyRM, L_q -
 *    L_d = 84 mH, its q current rising at 140 A/s while a load rolled it
 *    back at -14 rpm: e_q = +15 V against E_err 6 V, a false alarm with the
 *    estimate within 1 el.deg). A pi-off estimate gives p =
 *    -E_ext, an estimate that slips or spins against the rotor averages e_q
 *    to about 0. The k_dir term only where E_hat >= 3 E_err (an EMF that
 *    should stand out); below, r_dir > 1 only for an EMF that points
 *    backwards beyond the error bound. E_err bounds the q-axis voltage the
 *    model leaves out: the dead time's (k_dead u_dc), a resistance off by up
 *    to 100 % (R |i|), inductances off by up to 100 % acting through the d
 *    current (|w_hat| max(L_d, L_q) |i_d|; for the q current they turn e
 *    along d, not q), and a floor of 1 % of the dc link.
 * 2. Back-EMF slip (wherever the EMF measured stands out, whatever the
 *    loops' speed says). While the loops track, the EMF stands still in
 *    their frame; an estimate stuck or slipping while the rotor turns sees
 *    it turn at the slip, w - dtheta_hat/dt. Its turn per period, from the
 *    cross and dot products of e (in the loops' frame, through a two-pole
 *    pre-filter) with the last period's, low-passed:
 *      tan(slip Ts) = <e_{k-1} x e_k> / <e_{k-1} . e_k>
 *      r_slip = |slip| / (pi / t_lost)      where <e_{k-1} . e_k> >= E_err^2
 *    A slip of pi / t_lost turns the angle error by half a turn within the
 *    lock counter's time: from anywhere within 90 el.deg it passes 90. The
 *    model's errors (R, dead time, a carrier's leak) stand still in the
 *    loops' frame while they hold their current, or pulsate along an axis
 *    (no net turn), and weigh less than the EMF where it is judged; noise
 *    has no mean turn. The pre-filter (two poles at a quarter of the
 *    carrier's frequency, or of the Nyquist frequency without injection)
 *    keeps the carrier's leak out (17 times in amplitude); a turn's rate
 *    passes a filter unchanged.
 * 3. Mechanics (where the back-EMF is too small to judge: E_hat below
 *    3 E_err). The load the loops' motion implies,
 *      T_L_hat = T_ref - (J/p) dw_hat/dt - (B/p) w_hat   (low-passed twice)
 *    is within what a drive rated T_max can hold while the estimate tracks;
 *    a pi-off estimate reverses the torque the loops command, and their
 *    speed loop, seeing the rotor run the wrong way, raises it: T_L_hat
 *    then is 2 T_ref + T_L, about 2 T_max once it saturates:
 *      r_mech = |T_L_hat| / (k_mech T_max)
 *    (an estimate whose speed swings both ways implies loads of both signs:
 *    the net count of fs_lock sees |T_L_hat| above the bound more than half
 *    the time once its amplitude passes 1.4 times the bound).
 * 4. The loops' angle jumping (an event). Their angle's turn beyond what
 *    their speed accounts for, summed with a leak over t_lost / 2:
 *      jump = sum a^(k-n) (wrap(theta_hat_n - theta_hat_{n-1}) - w_hat Ts),
 *      a = exp(-2 Ts / t_lost)
 *    past pi/2 latches `jumped`. A tracking estimate corrects its angle by a
 *    few el.deg against its speed; one that finds the rotor again after it
 *    had lost it (an EMF observer taking over from an injection estimate
 *    that ran pi off: the saliency it tracks is the same at theta + pi)
 *    turns the loops' angle by the loss at once. A speed state off by dw
 *    adds dw t_lost / 2: past pi/2 only for dw > pi / t_lost, far beyond
 *    what a tracking estimate's speed is off by.
 * 5. The current loops' error |i_ref - i| low-passed against k_cur i_max:
 *    an estimate that spins against the rotor leaves the loops a rotating
 *    back-EMF they cannot follow. Not while the modulator cannot realise
 *    the voltage the loops ask at a speed that may explain it (the
 *    low-pass holds): their error is then the voltage limit's, which the
 *    flux weakening answers, whatever the angle, and 1. and 2. judge the
 *    EMF. The speed explains a short where its voltage could be half the
 *    modulator's linear limit with the largest flux the current limit
 *    allows: |w_hat| psi_max >= K_USPD u_dc / sqrt 3, psi_max = psi_f +
 *    max(L_d, L_q) i_max (a bound: the flux at any current is below it, so
 *    a short is counted only where the speed cannot explain it). Below, a
 *    short that lasts is a loops' frame off the rotor's asking voltage the
 *    machine does not need: a zoo machine's injection start with the
 *    controller's L_d, L_q x2 (B-LOCK's campaign, with the start-up fix of
 *    docs/held-runs.md) turned 100 el.deg off at 60 rpm, its loops
 *    over-modulated with their d current at -50 A against -0.1 A asked;
 *    held, this check read 0.13 and an overcurrent stopped the drive 7 ms
 *    after the true loss with no flag; counted, it flags the loss as it
 *    becomes true (without the fix the same run is flagged at 0.037 s,
 *    0.147 held, its loss true at 0.065). (SyR-e's THOR held at 4,147 rpm
 *    by a load machine, its torque stepped to the envelope's 25 N m:
 *    over-modulated for 20 ms, its d current at -7 A against -43 A, this
 *    check alone read a loss with the estimate 7 el.deg off, and the
 *    recovery that followed left it holding 21 N m.)
 * 6. The torque's sign (where the mechanics are judged). Inertia is
 *    positive: a change of the torque the loops command changes the
 *    rotor's acceleration, and that of an estimate following its motion,
 *    the same way, J da/dt = dT_e/dt - dT_L/dt; a reversed torque changes
 *    it the other way, whatever the load's level, the inertia's error or
 *    the voltage model's. Both sides through the same three low-passes
 *    (tau), so that neither leads:
 *      x = tau d(T_3)/dt = T_2 - T_3
 *      y = (J/p) tau d^2(w_3)/dt^2 = (J/p) (w_1 - 2 w_2 + w_3) / tau
 *    (T_k, w_k the k-th low-pass of T_ref and of the loops' speed), their
 *    products low-passed over t_lost:
 *      r_sign = 1 - <x y> / <x x>   where <x x> >= (k_exc T_max tau / t_lost)^2
 *                                   and the EMF measured points back, p < 0
 *    <x y> / <x x> is the acceleration's answer per unit of torque: J_hat /
 *    J on track less the load's share, about -c f with the torque reversed
 *    (c the fraction the angle error leaves, f the share of the rotor's
 *    motion the estimate follows): r_sign > 1 where it is negative. The
 *    sign decides, not a bound. Judged where the torque moved by k_exc T_max
 *    within t_lost, and where the EMF in the loops' frame has a component
 *    against their direction of rotation (1.'s p below 0: the reversed
 *    torque's second symptom, also a sign). A load step answers the other
 *    way round: the rotor slows first and the torque rises after it, which
 *    turns <x y> negative while the two meet in the filters, and for as
 *    long as an estimate's speed lags the rotor's (an injection observer
 *    at standstill: 20 ms behind under a step of 0.8 T_max); its EMF,
 *    where it stands out of the errors, points forward meanwhile.
 * Every low-pass has the time constant tau (the drive: lock_time / 4, as for
 * its other residuals) but 2.'s pre-filter and 6.'s products (t_lost); each
 * starts afresh when the checks are switched on.
 * Per step it uses the loops' Park transform (cos, sin) and current as the
 * step has them: no trigonometric call. Float32, no heap.
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
    float t_lost;             /* s, the lock counter's net time off track (fs_lock): the slip's and the jump's scale */
    float w_h;                /* rad/s, the injection's carrier (0: none) */
} fs_monitor_config;

typedef struct {
    fs_ab i;                  /* the loops' current, alpha-beta, A (fundamental when injecting) */
    fs_ab u_next;             /* the fundamental voltage just computed (acts after `delay`), V */
    float u_dc;               /* V */
    float theta, w;           /* the loops' angle, rad (at this sample), and electrical speed, rad/s */
    float cos_t, sin_t;       /* cos and sin of theta, as the loops' Park transform has them */
    fs_dq i_dq;               /* the loops' current in their frame, A */
    float T_ref;              /* N m, the torque the current reference commands */
    fs_dq i_err;              /* i_ref - i, A, in the loops' frame */
    bool on;                  /* the loops run sensorless: check; else the filters rest */
    bool u_limited;           /* the modulator could not realise the voltage asked (over-modulation): 5. holds */
} fs_monitor_in;

typedef struct {
    fs_monitor_config cfg;
    float b;                  /* the low-passes' step, 1 - exp(-Ts / tau) */
    float a_s;                /* the slip's pre-filter step */
    float x_max;              /* tan(pi Ts / t_lost): the slip bound's turn per period */
    float a_j;                /* the jump's leak per period, exp(-2 Ts / t_lost) */
    /* the step's constants, formed once as it formed them (the same bits) */
    float k_L, L_dq, L_max;   /* L_d / Ts, L_d - L_q, max(L_d, L_q) */
    float J_p, B_p;           /* J / p, B / p */
    float u_err;              /* k_dead + FS_MONITOR_U_FLOOR: the voltage error per volt of u_dc */
    float psi_spd;            /* Wb, psi_max sqrt 3 / FS_MONITOR_K_USPD: |w| psi_spd >= u_dc where the speed may explain a short (5.) */
    int n_warm;               /* FS_MONITOR_WARM tau / Ts, rounded up: the steps before a judgement */
    float T_mech, i_cur;      /* FS_MONITOR_K_MECH T_max, FS_MONITOR_K_CUR i_max */
    /* state */
    bool started;             /* the filters hold a value (on since the last reset) */
    bool jumped;              /* latched: |jump| went past pi/2 (4.) */
    int k;                    /* steps since started, up to n_warm (a count that grew for ever
                               * would overflow after 2^31 steps: 30 h at 20 kHz) */
    fs_ab i_prev;             /* the last sample's current */
    fs_ab u_q1, u_q2;         /* the voltages computed 1 and 2 steps ago */
    float th_prev, w_prev;    /* the loops' angle and speed at the last sample */
    float e_d, e_q;           /* low-passed EMF in the loops' frame, V */
    fs_dq e_s1, e_s2;         /* the EMF in the loops' frame through the pre-filter's two poles, V */
    float x_f, p_f;           /* low-passed cross and dot products of e_s2 with the last period's, V^2 */
    float w_f, T_f, id_f, i_f;    /* low-passed: speed, torque reference, d current, |i| */
    float iq_f;               /* low-passed q current (1.: its rate, the extended EMF's part that does not turn with the speed) */
    float ierr_f;             /* low-passed |i_ref - i| */
    float w_f2, w_f3, T_f2, T_f3; /* the second and third low-passes of the speed (w_f the first) and of the torque (T_f) (6.) */
    float c_xy, c_xx;         /* the torque's sign (6.): low-passed products over t_lost, N^2 m^2 */
    float b_c;                /* their step, 1 - exp(-Ts / t_lost) */
    float k_y;                /* J / (p tau), N m s per el. rad */
    float c_exc;              /* <x x> judged from, (k_exc T_max tau / t_lost)^2 */
    float jump;               /* rad, the loops' angle's turn beyond their speed (4.), leaky */
    /* the last step's residuals (<= 1 on track) */
    float r_dir, r_slip, r_mech, r_cur, r_sign;
    float E_hat, E_err;       /* V, the last step's expected EMF and error bound */
    float T_L_hat;            /* N m */
} fs_monitor;

/* The design constants (see above; reasons in fs_monitor.c). */
#define FS_MONITOR_K_DIR 0.25f
#define FS_MONITOR_K_MECH 1.2f
#define FS_MONITOR_K_CUR 0.4f
#define FS_MONITOR_K_EXC 0.1f

fs_status fs_monitor_init(fs_monitor *m, const fs_monitor_config *cfg);
void fs_monitor_reset(fs_monitor *m);
/* One step at the loops' rate; returns the largest residual (0 while off)
 * and sets `jumped` when the loops' angle jumped (fs_lock_latch). */
float fs_monitor_step(fs_monitor *m, const fs_monitor_in *in);

#endif /* FS_MONITOR_H */
