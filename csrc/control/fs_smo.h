/* Extended-EMF sliding-mode observer (yang2022, sec. 2).
 *
 * A current observer on the extended-EMF model in the stationary frame,
 * eq. (4), driven by the switching function z = k sat((i_hat - i)/delta),
 * eqs. (5)-(6). The EMF estimate e_hat is z through a low-pass filter whose
 * cutoff follows the estimated speed (Fig. 1), fed back with z so that
 * e_hat + z = e on the sliding surface, eq. (10). A normalized PLL, eq. (12),
 * with gains by pole placement, eq. (13), gives angle and speed.
 *
 * Gain: eq. (18) asks k > max|e| / 2; init computes the bound for the top
 * speed and current, refuses a configured k below it (FS_ERR_SMO_GAIN) and
 * designs k = margin * bound when k is 0.
 *
 * Boundary layer: in discrete time the correction k Ts / (L_d delta) of the
 * boundary layer must not exceed 1 (or the observer chatters by itself), so
 * delta is at least k Ts / L_d.
 *
 * Lag compensation: the filter lags z by pi/4 at its cutoff (the paper
 * compensates pi/4). With e_hat fed back as in eq. (4), z itself leads e, and
 * e_hat lags e by atan(w / (2 w_c)) = atan(1/2) at w_c = w. FS_SMO_LAG_EXACT
 * compensates that lag (default); FS_SMO_LAG_PAPER compensates pi/4.
 * Timing: the model is integrated over the last period with the voltage that
 * acted in it, so the EMF is that period's mean, half a period old: the angle
 * is advanced by w Ts / 2 to the sampling instant.
 *
 * Two forms (cfg.form):
 *   FS_SMO_FORM_PAPER: the above as the paper gives it (forward Euler on
 *     i_hat, the PLL of eqs. (12)-(13), lag as cfg.lag); kept for yang2022.
 *   FS_SMO_FORM_TRACKING (fullspeed's): the same sliding-mode current
 *     observer and adaptive filter, with four changes that remove its
 *     errors at speed, under load and in acceleration, and its instability
 *     when generating:
 *     1. the resistive and cross-coupling terms of eq. (4) take the mean of
 *        the measured currents at both ends of the period (trapezoid)
 *        instead of i_hat at its start: forward Euler leaves
 *        (R + w (L_d - L_q) J) w Ts i / 2 in the EMF, a load- and
 *        speed-dependent angle error (the bias at speed under load);
 *     2. the lag of the sampled loop (switching term one period late, the
 *        implicit-Euler filter, the EMF a period mean) is compensated
 *        exactly for the estimated speed: with the boundary layer's
 *        correction c = k Ts / (L_d delta) <= 1 and the filter's
 *        g = w_c Ts / (1 + w_c Ts), e_hat(n) = H(z) e_mean(n),
 *        H = g c z / ((z - 1 + g)(z - 1 + c) + g c z), so the angle at the
 *        sampling instant is arg(e_hat) - 1.5 w Ts + arg(den(e^{j w Ts}))
 *        (the continuous atan(w / 2 w_c) and the half period are this
 *        formula's limits for w Ts -> 0);
 *     3. a motion observer (fs_motion_obs) replaces the PLL: it integrates
 *        the torque of the measured current in the estimated frame,
 *        (phases / 2) p (psi_f + (L_d - L_q) i_d) i_q, so an acceleration
 *        is followed without lag (the PLL, type 2, lags a / bw_pll^2); its
 *        load estimate takes the rest. Its bandwidths are scheduled with
 *        the speed: the filter's cutoff follows the estimated speed, so its
 *        lag, compensated for that speed, grows when the estimate is slow
 *        and shrinks when it is fast (d lag / d w_hat = -0.4 / |w| at
 *        w_c = |w|): in the tracker's loop a right-half-plane zero at
 *        2.5 |w|. With a fixed triple pole at bw_pll that loop's damping
 *        falls with speed (250 rad/s on yang2022: 0.46 at 300 rad/s el.,
 *        0.21 at 157, 0.03 at 84, unstable below; the paper's type-2 PLL,
 *        0.58 at 157): on yang2022 at 300 rpm under rated load the tracker
 *        oscillated at 35 Hz, +-40 el.deg (beyond-full-range after its
 *        reversal). The damping depends only on w_o / |w| and w_c / |w|;
 *        with the tracker at FS_SMO_BW_PER_W |w| and the cutoff at least
 *        FS_SMO_WC_PER_BW times the tracker's bandwidth it is 0.70 or more at every
 *        speed (above bw_pll / FS_SMO_BW_PER_W the tracker stays at bw_pll
 *        and the cutoff at max(|w|, 3 bw_pll): 0.73 and more). The
 *        schedule's speed is the EMF's magnitude over psi_f, not the
 *        estimate's own speed (an estimate that has not yet caught a rotor
 *        would keep itself slow): the period's EMF, as the model sees it,
 *        follows exactly from the observer's recursion inside the boundary
 *        layer, e_n = e_hat_{n-1} + z_{n-1} + (z_n - z_{n-1}) / c, low-passed
 *        in magnitude at bw_pll; below w_valid the schedule holds the
 *        bandwidths of w_valid.
 *     4. where G (below) is positive, the cross-coupling term of eq. (4),
 *        w (L_d - L_q) J i, takes the speed the EMF's magnitude gives,
 *        w_emf, not the tracker's. With the tracker's w + dw the model
 *        puts dw (L_d - L_q) J i into the EMF it estimates: for the q
 *        current, dw (L_q - L_d) i_q across the EMF, which turns the
 *        measured angle by G dw, G = (L_d - L_q) i_q / (w psi_f),
 *        positive when generating on a machine with L_q > L_d. The
 *        tracker's triple pole (s + w_o)^3 becomes
 *        s^3 + 3 w_o (1 - g) s^2 + w_o^2 (3 - g) s + w_o^3, g = G w_o:
 *        damped more when motoring (g < 0), less when generating,
 *        unstable from g = 0.845 (Routh), earlier with the filter in the
 *        loop. Below bw_pll / 2 the schedule puts w_o at 2 |w|, so
 *        g = 2 (L_q - L_d) |i_q| / psi_f whatever the speed: on
 *        examples/own-machine's my48v (L_q - L_d = 0.38 mH, psi_f =
 *        13.9 mWb) 1.1 at 2 N m (20 A); generating at 500 rpm the tracker
 *        swung -26..+38 el.deg, and slowing from -2000 rpm under 2 N m it
 *        lost the rotor at 1400 rpm. The EMF's magnitude does not depend
 *        on the angle: in steady state |e| = |w psi_f + w_emf (L_d - L_q)
 *        i_d| (the q current's part is across it), so w_emf = dir |e| /
 *        (psi_f + (L_d - L_q) i_d) is w, and the loop left is static, of
 *        gain (L_d - L_q) i_d / (psi_f + (L_d - L_q) i_d) < 1 (0.2 on
 *        my48v at 25 A). |e| is the filtered EMF's magnitude over the
 *        sampled loop's gain |H| at the estimated speed (change 2's H):
 *        no lag beyond the filter's. The cost: psi_f enters the angle.
 *        psi_f off by a fraction f moves w_emf by f w and the angle by
 *        f (L_q - L_d) i_q / psi_f (3.9 el.deg per 10 % on my48v at
 *        25 A, 0.8 on yang2022 at rated current); and a current step
 *        inside the boundary layer, -(L_d - L_q) di_q/dt along the EMF,
 *        moves |e| for a filter time constant, and w_emf is noisier than
 *        the tracker's speed at low speed. Where G <= 0 (motoring, or no
 *        saliency) the tracker's speed only adds damping, and the term
 *        keeps it: with w_emf everywhere B-ZOO lost 2 of 50 machines
 *        (16, 96, handed over at 150-200 rpm motoring). A low-passed offset of the tracker's speed added to
 *        w_emf (steady state on the tracker's speed) destabilized the
 *        slowing my48v at rated torque (3 N m, lost at -600 rpm) and cost
 *        B-ZOO 5 machines at a slow low-pass: not kept. With this form
 *        motulator's SMO through a 3000 -> -3000 rpm step still loses the
 *        rotor at zero speed but is back within 50 ms (115 before); the
 *        lock monitor flags it since it weighs each step by how far its
 *        residual is over (fs_lock.h).
 *     Below the EMF of w_valid the correction is scaled down with the EMF
 *     (no angle is measured at standstill: the estimate holds instead of
 *     chasing noise), and so is the model's net torque T + T_d: the
 *     current's torque counts only once valid (a current in an unknown frame
 *     would accelerate the estimate away), and a load learnt at speed, held
 *     in T_d while the torque was dropped, accelerated the estimate at
 *     T_d / J (1070 rad/s^2, mechanical, on yang2022 at rated load) through every zero
 *     crossing. On becoming valid T_d starts at -T, so that the model's
 *     acceleration, nil until then, stays continuous. While not valid and its own EMF below that of w_valid, a
 *     caller that trusts another estimate (the blend: the injection's)
 *     hands it over (fs_smo_follow), so that the tracker leaves standstill
 *     on the rotor's angle, speed and load.
 *     A zero crossing is not a standstill: a rotor driven through zero
 *     (reversed by its load, or braked into the other direction) passes
 *     the band below w_valid in a few milliseconds at an acceleration the
 *     tracker has been measuring all along. Fading the model there left the
 *     estimate coasting at the band's edge while the rotor went through,
 *     and the EMF, turned about at zero and behind its filter, then pulled
 *     it the wrong way: 11.9 el.deg on the grin hub motor in B-REAL's
 *     reversal, and on yang2022 braked through zero at 2,100..6,600 rpm/s
 *     (i_q -8..-25 A, the encoder's loops) the estimate was lost (pi off)
 *     at each. So a tracker that leaves the band's top while valid, with
 *     its model's acceleration a = (p/J)(T + T_d) turning the speed through
 *     zero, runs on that model alone (fs_motion_obs_predict: no correction,
 *     T and T_d in full) until it is through, |w| >= w_valid the other way,
 *     and the EMF's filter, turned about at zero, has settled at its floor
 *     (3 / (FS_SMO_WC_PER_BW w_o)); at most twice the time a takes through
 *     the band and that settling. Not from a model that would take longer
 *     than FS_SMO_CROSS_MAX (a stop near zero speed, as above), and ended
 *     before zero when the EMF stays at w_valid's beyond its low-pass's
 *     settling (3 / bw_pll): an estimate knocked below the band while the
 *     rotor is not (test_smo_low_speed's 20 el.deg kick at w_valid) is the
 *     EMF's again within 12 ms. Not with an external direction (the blend:
 *     its injection has the low speeds, and fs_smo_follow hands its
 *     estimate over there). With it: grin 2.9 el.deg, yang2022 7.3, 5.6,
 *     3.0.
 *
 * Saturation (both forms, fs_smo_set_model): in steady state the extended
 * EMF of eq. (4) lies along q only where the model's L_q is the machine's
 * q secant inductance psi_q / i_q at the operating point (the model's
 * w L_q i_q must be the flux w psi_q); its magnitude over the speed is then
 * the active flux psi_d - L_q i_d. A drive that knows the machine's flux
 * map (fs_fluxmap.h) gives both for each step; L_d (the current observer's
 * dynamics) stays the configured one. With constant L_q the angle is off by
 * about (L_q,model - L_q) i_q / psi_a: 25 el.deg on the 2004 Prius MG2 at
 * 80 A with its rated-current inductances.
 *
 * Saturation's transient (the tracking form, fs_smo_transient): the
 * current observer's dynamics take L_d on both axes, so eq. (4)'s EMF holds
 * the rest of the machine's flux change, (L_inc - L_d) di_dq/dt with L_inc
 * the map's incremental inductances at the operating point. On a machine
 * whose q inductance is several times its d one that is most of a q current
 * change: the Baldor PM-SyRM (L_qq 0.14 H, L_d 0.017 H) slowing under a
 * generating load at 1,600..800 rpm made |e| swing 170..360 rad/s' worth
 * at 570 Hz; where G > 0 change 4 feeds that magnitude back through the
 * cross-coupling, the load estimate swung with it, the speed loop closed
 * the circle through the current, and the rotor was lost at 700 rpm. With
 * a map the caller (fs_drive.c, drive_smo_u) takes that voltage out of the
 * one that acted, fs_smo_transient: the period's change of the measured
 * current in the tracker's frame at the period's middle, less the frame's
 * turn w J i_dq, through the map's L_inc - L_d. Not while the caller injects (its current is then a
 * filter's estimate of the fundamental, whose steps are not the machine's).
 *
 * Convergence (both forms, for a hand-over): `converged` is set once the
 * current error stays in the boundary layer (r_i <= 1), |eps| below
 * sin 5 deg and the EMF's own speed within FS_SMO_AGREE of the estimate's
 * (at least of w_valid) for 4 time constants of the tracker without a
 * break (4 / bw_pll; the tracking form's at its scheduled bandwidth). The
 * tracking form's eps is its innovation low-passed at its bandwidth: the
 * angle error it is working off, not one sample's (the injection's fade-in
 * steps the fundamental current it sees); its EMF speed is w_emf (change
 * 4) low-passed the same way. The paper form's is dir e_raw / (psi_f +
 * (L_d - L_q) i_d). The residuals alone said converged on an estimate that
 * was consistently wrong: the paper form on my48v generating at the
 * reversal, 45-70 el.deg off with its PLL speed beside the rotor's (an
 * extended EMF turned by a speed error, eq. (4), is an EMF the PLL locks
 * onto), and a tracker locked pi off with the direction the wrong way
 * (started at standstill below w_valid: its speed and its EMF's then
 * have opposite signs).
 */
#ifndef FS_SMO_H
#define FS_SMO_H

#include "fs_fluxmap.h"
#include "fs_lpf.h"
#include "fs_motion_obs.h"
#include "fs_pll.h"
#include "fs_transforms.h"
#include "fs_types.h"

typedef enum { FS_SMO_LAG_EXACT = 0, FS_SMO_LAG_PAPER = 1 } fs_smo_lag;
/* The tracking form's schedule (header, change 3): its tracker at this
 * fraction of the speed the EMF gives, its filter's cutoff at least this
 * multiple of the tracker's bandwidth: damping >= 0.70 at every speed */
#define FS_SMO_BW_PER_W 2.0f
#define FS_SMO_WC_PER_BW 3.0f
/* `converged` needs the EMF's speed within this fraction of the estimate's
 * (at least of w_valid): psi_f off by 20 % (B-ROBUST's range) moves it 25 % */
#define FS_SMO_AGREE 0.4f
/* The longest zero crossing the tracker takes on its motion model alone, s
 * (fs_smo_step): one slower than that is a stop near zero speed, where the
 * model's torque fades with the EMF as before */
#define FS_SMO_CROSS_MAX 0.5f
/* The furthest a hold's model alone may drift on a torque change it cannot
 * place (fs_smo_hold), rad: `converged`'s bound on the innovation (5 el.deg),
 * so that the correction resumes on an error it would still call settled */
#define FS_SMO_HOLD_DRIFT 0.0873f
typedef enum { FS_SMO_FORM_PAPER = 0, FS_SMO_FORM_TRACKING = 1 } fs_smo_form;

typedef struct {
    float Ts;            /* s */
    float R_s, L_d, L_q, psi_f;
    float w_e_max;       /* top electrical speed for the gain bound, rad/s */
    float i_max;         /* top current for the gain bound, A; the current estimate is held within 16 i_max */
    float k;             /* switching gain, V; 0: designed as margin * bound */
    float margin;        /* >= 1 */
    float delta;         /* boundary layer, A; floored at k Ts / L_d */
    float w_c_min;       /* filter cutoff floor, rad/s */
    float bw_pll;        /* PLL double pole, rad/s */
    float w_valid;       /* |w_hat| below this: not valid, rad/s (el.) */
    int lag;             /* fs_smo_lag (FS_SMO_FORM_PAPER) */
    int form;            /* fs_smo_form */
    float J, B;          /* FS_SMO_FORM_TRACKING: inertia kg m^2 (> 0), viscous friction N m s */
    int pole_pairs;      /* FS_SMO_FORM_TRACKING: >= 1 */
    int phases;          /* FS_SMO_FORM_TRACKING: the torque's phases / 2 (3 or 5) */
    int dir_external;    /* 1: the direction the PLL error assumes is the caller's (fs_smo_set_dir) */
} fs_smo_config;

typedef struct {
    fs_smo_config cfg;
    float k, delta;      /* designed */
    float k_bound;       /* eq. (18) for w_e_max, i_max */
    float i_hat_max;     /* the current estimate's bound, 16 i_max (fs_smo_step) */
    fs_ab i_hat;         /* estimated current */
    fs_ab z;             /* switching function output */
    fs_lpf lpf;          /* e_hat = lpf.y */
    fs_pll pll;          /* FS_SMO_FORM_PAPER */
    fs_motion_obs mo;    /* FS_SMO_FORM_TRACKING */
    fs_ab i_prev;        /* the current measured at the last step */
    bool have_prev;
    float k_T;           /* (phases / 2) p, N m per (V s A) */
    float e_valid;       /* |e_hat| at w_valid: below it the tracker's correction fades */
    float c_bl;          /* the boundary layer's correction per step, k Ts / (L_d delta) <= 1 */
    float w_sched_min;   /* FS_SMO_FORM_TRACKING: the schedule's speed floor, rad/s (el.) */
    float a_emf;         /* the EMF magnitude's low-pass per step, at bw_pll */
    float e_raw;         /* |the period's EMF|, low-passed, V */
    float psi_x;         /* psi_f + (L_d - L_q) i_d at the last step (the EMF over the speed), Wb */
    float w_emf;         /* FS_SMO_FORM_TRACKING: the speed the filtered EMF's magnitude gives, signed dir (change 4), rad/s */
    bool gen;            /* FS_SMO_FORM_TRACKING: G > 0 at the last step (generating with saliency): the cross-coupling on w_emf (change 4) */
    float w_emf_lp;      /* FS_SMO_FORM_TRACKING: w_emf low-passed at the tracker's bandwidth, as eps (`converged`) */
    int n_settle, k_settled;  /* converged after n_settle steps in a row */
    bool converged;
    float theta;         /* estimated angle at the sampling instant, rad */
    float w;             /* estimated electrical speed, rad/s */
    bool valid;
    int n_hold;          /* FS_SMO_FORM_TRACKING: steps left on the motion model alone at the caller's word (fs_smo_hold) */
    int n_cross;         /* FS_SMO_FORM_TRACKING: steps left at most of a zero crossing on the motion model (fs_smo_step) */
    int n_settle_dir;    /* the EMF filter's settling at its floor cutoff when the crossing began, steps */
    int n_dir;           /* in a crossing: 0 before zero, then counting down the filter's settling to 1 */
    int n_emf;           /* in a crossing, before zero: steps in a row the EMF has stayed at w_valid's */
    float dir;           /* direction of rotation the EMF angle assumes: +1, -1 (the paper form: hysteresis at w_valid; the tracking form: its speed's sign) */
    float r_i;           /* max |current error| over delta at the last step: <= 1 while sliding */
    float eps;           /* the last normalized PLL error, sin(theta - theta_pll) */
    float e_mag;         /* |filtered EMF|, V: about |w| psi_f / sqrt 2 behind the filter when it tracks */
    float L_q_run;       /* the model's L_q this step: cfg.L_q, or a flux map's secant (fs_smo_set_model) */
    float psi_run;       /* with a map: the active flux psi_d - L_q i_d (the EMF over the speed), Wb */
    bool map;            /* fs_smo_set_model was called: psi_run replaces psi_f + (L_d - L_q) i_d */
    /* the hold's drift (fs_smo_hold), last: beside n_hold they moved the
     * members after them to longer offsets, 116 B more of the image's flash */
    float T_hold;        /* FS_SMO_FORM_TRACKING: the current's torque at the last corrected step, N m: a hold ends where the
                            torque has left it (fs_smo_hold) */
    float w_hold;        /* in a hold: the speed (rad/s) the torque's change since it began has given the model */
    float th_hold;       /* ... and the angle, rad */
    float t_hold;        /* ... and the hold's length, s (the speed's bound) */
} fs_smo;

fs_status fs_smo_init(fs_smo *o, const fs_smo_config *cfg);
void fs_smo_reset(fs_smo *o, float theta, float w);
/* With dir_external: the direction of rotation from an estimate the caller
 * trusts at low speed (the sign of w; w = 0 keeps it). In the blend the
 * injection side knows the direction long before the back-EMF does, and an
 * observer that took it from its own speed at standstill could lock pi off. */
void fs_smo_set_dir(fs_smo *o, float w);
/* FS_SMO_FORM_TRACKING, valid: the current the caller gives is disturbed
 * for the next n steps in a way the model cannot explain (the injection's
 * fundamental while its carrier fades in or out: fs_hfi's filters follow a
 * changing carrier only within their settling, and on a saturating machine
 * its harmonics pass them), so the tracker runs on its motion model alone
 * meanwhile (the current's torque and its load in full, no correction), as
 * through a zero crossing. No effect otherwise.
 *
 * The model alone knows the rotor's motion only while the torque stays
 * where the load estimate balanced it: a torque change dT in the hold goes
 * to the rotor (a free rotor) or to the load (a rotor held by a load
 * machine, a vehicle), which the model cannot tell apart without the EMF,
 * and the two differ by p dT t^2 / (2 J) after a time t. The hold ends, and
 * the EMF corrects again, as soon as the difference so far, with its speed
 * carried over the hold's remaining steps, would pass FS_SMO_HOLD_DRIFT (the
 * integrals, not the torque of one step: the fading carrier's harmonics
 * move the current's torque by tens of N m from step to step, and a hold
 * ended on them corrects on the EMF they disturb: the Prius reversing
 * under 200 N m, its tracker's speed jumped by 200 rpm). On the 2004 Prius
 * MG2 held at 294 rpm by a load machine, the torque asked from 40 to 486
 * N m just as the estimate passed the injection's stop speed: the model
 * alone, 9.6 ms on a 0.035 kg m^2 rotor, ran the estimate to 660 rpm and
 * 100 el.deg off.
 *
 * The same for the speed that difference gives: the hold ends where it,
 * carried over a hold's length, would pass FS_SMO_HOLD_DRIFT. The angle's
 * bound alone let the speed go: the speed is carried past the hold's end
 * until the EMF's correction has worked it off, and the caller decides on
 * it meanwhile (the blend's weight, the injection's stop and resume). On
 * the Prius held at 293.1 rpm (B-REAL's 294 less 0.2 %), the carrier's
 * resume took its peak off the current limit, 30 N m of the 486, and the
 * hold's model ran 284 -> 226 rpm within the angle's bound, below the
 * blend's band top (267): the blend left the tracker for its own model and
 * lost the rotor. With this and the speed innovation (fs_smo_speed): 25 of
 * 25 neighbours 0.1 % apart hold (bench/held_margin.py --k 12), 16 on main;
 * the speed innovation alone 24, this alone 20. */
void fs_smo_hold(fs_smo *o, int n);
/* FS_SMO_FORM_TRACKING, while not valid and its own EMF (e_raw) below that
 * of w_valid: the tracker takes an estimate the caller trusts (angle,
 * electrical speed, and T_d the load torque as fs_motion_obs has it, N m),
 * so that it runs on its own EMF from the right state once the EMF is
 * there. No effect on the paper form, once valid, or with an EMF that says
 * the rotor turns faster (the caller's estimate may have slipped). */
void fs_smo_follow(fs_smo *o, float theta, float w, float T_d);
/* From a flux map, for the next step (header, saturation): the q secant
 * inductance and the active flux at the operating point. */
void fs_smo_set_model(fs_smo *o, float L_q, float psi_a);
/* The tracking form, valid, correcting (no hold, no zero crossing) and not
 * converged, after fs_smo_step: a speed innovation, the speed of the EMF's magnitude over the
 * active flux (e_raw / psi_x, the schedule's: low-passed at bw_pll and kept
 * where the current leaves the boundary layer) less the tracker's, weighted
 * k in [0, 1]: w += k 2 w_o Ts dw, T_d += k (J / p) w_o^2 Ts dw, a double
 * pole at the tracker's bandwidth w_o.
 *
 * Why: on a saturated map the EMF's angle shows only g of an angle error
 * (docs/held-runs.md: g = 1 + (L_qd i_q - (L_qq - L_q) i_d) / psi_a; the
 * 2004 Prius MG2 0.3..0.4 at its current limit), so the tracker corrects
 * at g of its bandwidth, while the EMF's magnitude gives the speed whatever
 * the angle. A torque the model feeds forward on J that the shaft does not
 * follow (a load machine holding it) is an acceleration error a; with
 * k = 1 - g the speed carries what the angle no longer does: the peak
 * angle error, in units of a / w_o^2 (the linear tracker's 0.27 at g = 1),
 * is 0.89 at g = 0.35 without, 0.44 with (the EMF's speed behind its
 * low-pass at 1.3 w_o), and g = 1 leaves the tracker as it was. The cost:
 * the flux map's error in psi_x is the speed's, and against the angle's
 * loop (type 3, no steady error) it holds a steady one; so the speed acts
 * only until the tracker has converged (fs_smo.h, convergence), and the
 * caller leaves out the flux weakening, where psi_x is small. Taken at
 * every convergence, on the Prius held at 291 rpm it read 2.5 % low and
 * held the estimate 2 rpm under the shaft, below the injection's resume
 * (288 rpm); taken in flux weakening as well, B-REAL's Baldor PM-SyRM held
 * at 1,844 rpm made half its torque (0 of 25 neighbours), and with the
 * convergence's bound but in flux weakening SyR-e's THOR at 2,765 and
 * 3,456 rpm held 18 and 6 of 25. The 2004 Prius MG2 held at 294 rpm and
 * its step to 486 N m (B-REAL): see fs_smo_hold. */
void fs_smo_speed(fs_smo *o, float k);
/* From a flux map (header, saturation's transient): the voltage
 * (L_inc - L_d) di_dq/dt, stationary frame, that the map's incremental
 * inductances at p put across the machine over the period ending with the
 * current i; the caller takes it from the u it gives fs_smo_step (call it
 * just before, after any fs_smo_follow). Zero in the PLL form. */
fs_ab fs_smo_transient(const fs_smo *o, fs_ab i, const fs_fluxmap_point *p);
/* One step: i is the current sampled now, u the stationary voltage that
 * acted during the period that ended now. Returns the angle. */
float fs_smo_step(fs_smo *o, fs_ab i, fs_ab u);

#endif /* FS_SMO_H */
