/* Current references within the voltage limit, from the flux map: flux
 * weakening that uses the whole current limit, and MTPV.
 *
 * In steady state the voltage is about w_e |psi| (the resistive drop
 * aside), so a speed w_e and an available voltage u_lim allow the fluxes
 * |psi(i)| <= psi_lim = u_lim / |w_e|. Below base speed (psi_lim at least
 * the flux of MTPA at i_max, psi_mtpa) MTPA holds every torque. Above it
 * the most torque inside the current limit and the flux limit is T_max(psi_lim):
 * on the flux limit |psi| = psi_lim where the current limit cuts it, or at
 * its maximum along it (MTPV: maximum torque per volt, where the machine's
 * characteristic current lies inside the current limit); and a smaller
 * torque takes the least current that makes it within both limits: MTPA
 * while that is inside the flux limit, else the point of the flux limit
 * where the torque is that, on the side of less current.
 *
 * init tabulates this on the map (fs_fluxmap.h) for x = psi_mtpa / psi_lim
 * (the speed over base speed at the same voltage) from 1 to x_end in
 * FS_FWMAP_NX rows, spaced as the square of the row's index (dense near
 * base speed, where the flux limit moves fastest), each at FS_FWMAP_NT torques from 0 to T_max(x): along
 * the flux limit psi_lim e^{j delta}, delta from the d axis up, the current
 * is found by Newton's method on the map (its incremental inductances), the
 * torque rises to T_max and the current's magnitude with it. step
 * interpolates the table bilinearly in x and T / T_max(x), and holds T_max.
 * x_end is the machine's top speed over its base speed, x_top = psi_mtpa /
 * psi_min, psi_min the least flux any current within the limit makes (on
 * the d axis, at -i_max or at the characteristic current), or
 * FS_FWMAP_X_MAX (8) where that is further (a characteristic current within
 * the limit: no top speed; beyond 8 the last row held). Beyond x_top no
 * current makes torque within both limits: the rows there hold the least
 * flux's current, so that a rotor driven beyond the top speed (a load
 * machine, an overshoot the trim follows) meets the most weakening the
 * limit allows, not none. With rows to 8 on a hub motor whose top speed is
 * 1.5 x base (the Grin all-axle, characteristic current 3.4 x i_max) four
 * rows covered its whole flux-weakening range, the fifth held no current:
 * interpolated to it, the references weakened less and less near the top
 * speed; once the trim had wound x beyond it they asked for no current,
 * the back-EMF outgrew the voltage and drove 33 A of braking current.
 *
 * Against the voltage-feedback flux weakening (fs_fw.h), which adds a d
 * current while the voltage saturates and keeps the q current the speed
 * loop asks, these references are feed-forward: the torque the machine can
 * make at a speed is asked for directly, with all the current the limit
 * allows (on the 2004 Prius MG2's map at 1540 rpm: 358 N m on 250 A, where
 * the feedback held 190 N m on 125 A).
 *
 * The references meet the flux limit in steady state; while the
 * reference moves (an acceleration deepens it continuously) the current
 * loops ask more, and at the modulator's edge the d current can no longer
 * be driven deeper. fs_fwmap_trim closes the loop on the voltage the
 * current regulators ask: an integrator on its excess over the plan, at
 * FS_FWMAP_TRIM_PER_BW of the current loop's bandwidth (well inside it),
 * raises x, the speed ratio the flux limit is taken at (x (1 + trim), trim
 * up to 1), and lets it back down as the excess goes; below the plan it
 * lowers x (down to 1, base speed, and at most by half; at
 * FS_FWMAP_TRIM_APPROACH of the rate, towards the limit), so that in
 * steady state the voltage asked is the plan's: the resistive drop, planned
 * for as R_s |i| (its whole magnitude against the flux's voltage), and the
 * map's interpolation leave the references inside the limit by a little,
 * which near the top speed is much torque (the ODrive D6374 at 0.9 of its
 * top speed held 9 % below its envelope, the Anaheim BLY171D at 2 x base
 * 13 %, where the torque falls 10 % for 1 % of voltage). It lowers x only
 * where the current's flux is on the plan's flux limit psi_mtpa / x
 * (within FS_FWMAP_INSIDE of it): inside it, on MTPA at a light load, the
 * voltage is below the plan because the operating point is, not the plan
 * wrong, and the trim holds. Lowering x there too wound it down to x = 1
 * over a light-load acceleration past base speed (SyR-e's THOR at 7 A,
 * 2,074 to 3,600 rpm: trim -0.43); when the voltage came to the limit it
 * had that to unwind at the rate of a 1 % excess, the references stayed on
 * MTPA 100 rpm past the flux limit, the modulator over-modulated for 15 ms,
 * i_d ran from -5 to +3 A, the torque fell from 5.7 to 1.0 N m and the
 * sensorless angle swung 3.7 el.deg (0.8 with the hold). On the 2004 Prius
 * MG2's full range (sensorless, 5000 rpm in flux weakening) the largest
 * angle error was 7.7 el.deg without it, 3.8 with it.
 */
#ifndef FS_FWMAP_H
#define FS_FWMAP_H

#include "fs_fluxmap.h"
#include "fs_mtpa.h"
#include "fs_transforms.h"
#include "fs_types.h"

enum { FS_FWMAP_NX = 16, FS_FWMAP_NT = 12, FS_FWMAP_NTAB = 192 };   /* NTAB = NX NT */
#define FS_FWMAP_X_MAX 8.0f

typedef struct {
    const fs_fluxmap *map;   /* read at init only */
    float i_max;             /* A */
    float k_T;               /* (phases / 2) p: torque per (flux x current) */
    float Ts, bw_current;    /* s, rad/s: the trim's rate (header) */
} fs_fwmap_config;

#define FS_FWMAP_TRIM_PER_BW 0.05f
/* The trim's rate towards the voltage limit (lowering x: the voltage asked below the plan) over its
 * rate away from it. Beyond the limit the d current is lost within a few periods (the current loops
 * saturate and the back-EMF drives i_d towards zero, the flux and the voltage asked rise further), inside
 * it only some torque: approached as fast as it is left, the trim overshot below its steady value, the
 * d current collapsed, the trim wound back up, and with the back-EMF observer's angle in the loop (its
 * torque feed-forward wrong while the loops saturate) this made a 15 Hz limit cycle: on SyR-e's THOR held
 * by a load machine at 2,765..3,800 rpm the trim swung between -0.19 and +0.52 and the drive held 14 to
 * 80 % less torque than with the encoder; approached at a quarter of the rate, within 0.2 % of it */
#define FS_FWMAP_TRIM_APPROACH 0.25f
/* How far inside the plan's flux limit the current's flux may lie and still count as on it (the trim's
 * hold, header): the flux at the measured current trails the reference's on the limit by the current
 * loops' tracking and the table's bilinear interpolation between rows. Measured on SyR-e's THOR's
 * sensorless full range (bench/syrm_peer.py's job): 0.005 let the 15 Hz limit cycle at the voltage limit
 * through after the load step (steady 7.8 el.deg), 0.02 to 0.1 settle alike (0.3 to 2.6), 0.2 holds
 * too little to matter (the acceleration's 3.0 el.deg again); 0.05, the middle of that range */
#define FS_FWMAP_INSIDE 0.05f

typedef struct {
    float psi_mtpa;          /* Wb, |psi| of MTPA at i_max (x = 1) */
    float inv_dx;            /* 1 / (x_end - 1): the rows' span (header) */
    float k_trim;            /* the trim's integral gain per step, Ts FS_FWMAP_TRIM_PER_BW bw_current */
    float trim;              /* its state, >= 0 (header) */
    float T_max[FS_FWMAP_NX];               /* N m at x_k = 1 + k dx */
    float i_d[FS_FWMAP_NTAB], i_q[FS_FWMAP_NTAB];   /* A at (x_k, T_max(x_k) j / (NT - 1)), index k NT + j; i_q >= 0 */
} fs_fwmap;

/* mtpa: the map's locus at the same i_max (fs_mtpa.h), which the rows
 * take below the flux limit; its segment cache moves. */
fs_status fs_fwmap_init(fs_fwmap *f, const fs_fwmap_config *cfg, fs_mtpa *mtpa);
void fs_fwmap_reset(fs_fwmap *f);
/* The speed ratio x = (1 + trim) psi_mtpa |w_e| / u_lim for a voltage and a
 * speed (<= 1: MTPA holds). */
float fs_fwmap_ratio(const fs_fwmap *f, float u_lim, float w_e);
/* The trim (header): u the voltage the current regulators asked last, u_plan
 * the voltage planned for, psi |psi| at the measured current (Wb), x this
 * step's ratio (fs_fwmap_ratio); while x > 1 (in flux weakening). */
void fs_fwmap_trim(fs_fwmap *f, float u, float u_plan, float psi, float x);
/* For x > 1: the current for torque T_ref (either sign), T_ref held at
 * T_max(x) (*T_real: the torque asked of the current). */
fs_dq fs_fwmap_step(const fs_fwmap *f, float x, float T_ref, float *T_real);

#endif /* FS_FWMAP_H */
