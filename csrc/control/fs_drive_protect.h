/* The drive's protection (not part of the public API; fs_drive.c calls it):
 * what the drive does when its monitor says lock is lost, and the overspeed
 * stop. A firmware answers a halt (out.fault) by turning the PWM off.
 *
 * Loss of lock with recovery on (cfg.lock_recover; fs_drive.h):
 *   1. The zero-current wait (FS_PHASE_RECOVER, cfg.t_recover). The current
 *      loops hold i_d = i_q = 0: the rotor gets no torque, as with the PWM
 *      off, and the voltage the loops apply is the back-EMF (e = u - R i;
 *      their ripple's L di/dt averages out), which a drive without
 *      phase-voltage sensors could not read with the PWM off. The back-EMF
 *      observer (fs_smo.h) runs on that voltage and the measured current
 *      as in every step, and the drive measures the EMF's magnitude,
 *      low-passed over lock_time / 4: |e| = |w| psi_f at zero current, the
 *      rotor's speed whatever any estimate says: on the lock campaign's
 *      losses with recovery on (yang2022, motulator, zoo 0-2), within 12 %
 *      of the true speed up to where the back-EMF nears the link's voltage;
 *      beyond, the loops cannot hold zero current and it reads the most
 *      they apply (a rotor the halt below stops).
 *   2. At the end of the wait:
 *      - where the back-EMF observer tracks (valid, converged: its
 *        residuals settled and its speed agreeing with its EMF's, fs_smo.h;
 *        in the blend above w_lower), the flying restart: every estimate
 *        takes the observer's angle and speed, the speed loop starts from
 *        its speed with no torque, and the loops go on;
 *      - else at low speed (the EMF below that of the speed where the
 *        observer is trusted: the blend's w_lower, the I/f start's hand-over
 *        speed, the observer's w_valid; any speed with the injection
 *        alone), the start sequence again: polarity detection and injection
 *        (which kept following the saliency), or the I/f start;
 *      - else (at speed where the observer does not track, or at low speed
 *        without a start sequence: the SMO started on the encoder), the
 *        halt, FS_FAULT_LOCK.
 *   A loss after lock_retries recoveries halts with FS_FAULT_LOCK.
 * Overspeed (cfg.w_over > 0): the loops' speed above w_over halts with
 * FS_FAULT_OVERSPEED (one comparison a step; not during the wait, where the
 * lost estimate's speed means nothing: after a flying restart the loops'
 * speed is the observer's again). The limit is designed by the caller
 * (fullspeed.design.rules: 1.2 x the fastest the drive is designed for or
 * asked).
 * Above the speed where the line-to-line back-EMF's peak exceeds the dc
 * link, the PWM off lets the inverter's diodes rectify it into the link
 * (braking current, the link's voltage rising): a firmware there applies
 * the active short circuit (all low-side switches on) instead.
 */
#ifndef FS_DRIVE_PROTECT_H
#define FS_DRIVE_PROTECT_H

#include "fs_drive.h"

/* A limit that no finite speed passes (the drive's floats stay finite:
 * INFINITY would read as a diverged state) */
#define FS_DRIVE_NO_LIMIT 3.0e38f

/* Halt (FS_PHASE_HALT) with the fault, from now on; with out, this step's
 * output says so (duties 1/2: the firmware turns the PWM off). */
void fs_drive_halt(fs_drive *drv, int fault, fs_drive_out *out);
/* The monitor latched a loss with recovery on: the recovery, or the halt
 * once the retries are spent (out->lock_lost then stays set). */
void fs_drive_lock_lost(fs_drive *drv, fs_drive_out *out);
/* One step of the zero-current wait, on the fundamental current (the
 * loops'): the EMF measured, and at its end the flying restart, the start
 * sequence again or the halt. */
void fs_drive_recover_step(fs_drive *drv, fs_ab i_ab);

/* The realised fundamental voltage that acted over the period that ended now. */
static inline fs_ab drive_u_past(const fs_drive *drv)
{
    return drv->cfg.delay > 0.5f ? drv->u_hist[1] : drv->u_hist[0];
}

#endif /* FS_DRIVE_PROTECT_H */
