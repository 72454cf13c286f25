/* The drive step: the one function a PWM interrupt calls.
 *
 * It takes the sampled phase currents, dc-link voltage and encoder angle,
 * runs the mode's loops and returns the duties for the next update instant.
 * Modes: open-loop voltage in a frame turning at a given speed (u_d, u_q or
 * V/f), current control, speed control (speed PI -> MTPA -> current control).
 * The angle comes from the angle source: the encoder (with a PLL for speed),
 * or an external angle (tests, and the slot where estimators plug in), or
 * the sliding-mode observer, optionally after an I/f start from standstill,
 * the rotating HF injection estimator, or the blend of the two (yang2022);
 * the rotating-injection sources start with a magnet polarity detection;
 * or the square-wave injection estimator (yu2022), with which the loops run
 * at the carrier's zero crossings, every other sample.
 * Three or five phases: five-phase currents are taken in the fundamental
 * plane of the VSD (fs_vsd.h) and modulated by nearest-four-vector PWM
 * (fs_pwm5.h), which keeps the third-harmonic plane's voltage at zero.
 * In speed mode, flux weakening adds negative d-current above base speed.
 * Sensorless, a loss-of-lock monitor watches the estimator in use and, with
 * recovery on, a loss starts the recovery phase; the operating stage
 * (fs_drive_stage) tells where the drive is in its start-up sequence.
 * The converter is a two-level voltage-source inverter on the sampled dc
 * link, or an indirect matrix converter (zou2021, fs_imc.h) on the sampled
 * input voltages: the rectifier stage's intervals and, for the inverter
 * stage, the period mean of the virtual dc link in place of u_dc.
 *
 * Integration contract (what a firmware must do; firmware/drive_app.c does it
 * for a board behind firmware/board.h; README "On a microcontroller"):
 *
 * Configuration. `fullspeed export SCENARIO --out DIR` writes the
 *   fs_drive_config a simulation used as C source; it carries config_size,
 *   and fs_drive_init refuses a configuration written for another layout.
 *   The gains are designed inside fs_drive_init from the machine's
 *   parameters, so the firmware computes what the simulator computed.
 * Sampling. Once per control period Ts, at the carrier's peak of a
 *   centre-aligned PWM (all poles on the low rail, the zero vector in which
 *   low-side shunts carry the phase currents); with double sampling
 *   (Ts = T_pwm / 2) also at the valley, which needs in-line current sensors.
 *   At that instant: i_ph[k], A, positive flowing from the inverter into the
 *   machine's terminal k, offset-corrected (measure the ADC's zero with the
 *   PWM off); u_dc, V; theta_m_enc, mechanical rad, any range, 0 when the
 *   rotor's d axis (the magnet's north pole) is on phase a's axis (the
 *   encoder's zero offset is the firmware's to subtract; theta_e = p theta_m).
 *   Low-side shunts see a phase only while its low-side switch is on: a leg
 *   whose duty is above 1 - t_min / T_pwm (t_min the ADC's sampling window
 *   and the shunt's settling) leaves no time, and over-modulation and flux
 *   weakening take duties to 1 (the hexagon's edge). Take that phase as
 *   minus the sum of the others (no neutral: i_a + i_b + i_c = 0), or use
 *   in-line sensors. The simulator samples the currents ideally.
 * Duties. out.duty[k] in [0, 1] is the fraction of the carrier period that
 *   leg k's high-side switch is on (its pole's mean voltage is
 *   (duty - 1/2) u_dc about the link's midpoint); write duty x period to the
 *   compare registers with preload, so they take effect at the next update
 *   event: the drive compensates that one-period delay (config delay = 1;
 *   delay = 0 assumes they act at once, for idealised runs only). The
 *   hardware dead time is the firmware's; t_dead_comp compensates it.
 * Protection. The drive limits its current references to i_max and its
 *   voltage to the modulator's hexagon, refuses a bad configuration (naming
 *   the field), watches the estimator and acts on a loss of lock
 *   (fs_drive_protect.h): with lock_recover it holds zero current, then
 *   catches the spinning rotor on its back-EMF observer (a flying restart),
 *   runs its start sequence again at low speed, or halts with out.fault =
 *   FS_FAULT_LOCK; without, out.lock_lost is latched and it goes on. It
 *   halts with FS_FAULT_OVERSPEED when its speed passes w_over, and where
 *   its polarity detection could not decide, with FS_FAULT_POLARITY. Halted,
 *   its duties are 1/2 from then on: the firmware turns the PWM off on a
 *   fault (above the speed where the line-to-line back-EMF's peak exceeds
 *   the link, the active short circuit instead), and on lock_lost, within
 *   the same interrupt, and reports it. It does NOT trip on overcurrent
 *   (i_trip lives in the simulator, not here), on dc-link over- or
 *   under-voltage, temperature, or a failed sensor, and does not check its
 *   inputs for NaN: the firmware turns the PWM off on those.
 * References. The loops follow in.w_m_ref (speed mode) or i_d_ref, i_q_ref
 *   (current mode) as given: a speed step asks for T_max at once and the
 *   estimators see the fastest change the machine can make. A firmware
 *   ramps the reference as the scenario it was proven on does (the
 *   catalog's ramp theirs; firmware/drive_app.c ramps at app_config.ramp).
 * Start-up. fs_drive_init (the PWM off), measure the current offsets, enable
 *   the PWM (bootstrap charged) and call fs_drive_step from the next update
 *   interrupt on, with the drive's state as fs_drive_init (or fs_drive_reset)
 *   left it. in.sensorless = 1 from the first step with the injection
 *   sources (HFI, blend: the polarity detection runs first, rotor at
 *   standstill, ~0.1 s of d-current pulses), the square wave, or the SMO with
 *   an I/f start; with the SMO alone, 0 (the encoder) until the speed is
 *   above the observer's valid speed, then 1. After the PWM was off,
 *   fs_drive_reset before stepping again (the sequence starts over).
 * Timing and re-entrancy. fs_drive_step must complete within Ts of its
 *   sampling instant, before the next update event. On a Cortex-M4F at
 *   -O2 a step takes about 1,280-2,910 instructions on average by angle
 *   source, 4,112 at most (the blend); 2,455 on average and 3,443 at most
 *   over the blended full-range run in the firmware's build (-flto):
 *   bench/pil.py measures it per mode. It
 *   touches only *drv, *in and *out (no globals, no heap): instances are
 *   independent, one step may run per instance at a time, and
 *   fs_drive_init, fs_drive_reset and fs_drive_step on one instance must not
 *   interrupt each other. It uses the FPU (lazy stacking keeps an interrupt
 *   that does correct).
 * Memory. sizeof(fs_drive) is about 7.1 KB (bench/pil.py reports the
 *   target's, 7,120 B; a 64-bit host's is up to 16 B more: its pointers);
 *   its stack is under 800 B (bench/pil.py: 728 B on the static call graph,
 *   328 B the measured high-water mark).
 */
#ifndef FS_DRIVE_H
#define FS_DRIVE_H

#include "fs_current_ctrl.h"
#include "fs_dtcomp.h"
#include "fs_xyctrl.h"
#include "fs_blend.h"
#include "fs_fluxmap.h"
#include "fs_fw.h"
#include "fs_fwmap.h"
#include "fs_hfi.h"
#include "fs_ident.h"
#include "fs_if_start.h"
#include "fs_imc.h"
#include "fs_lock.h"
#include "fs_monitor.h"
#include "fs_motion_test.h"
#include "fs_mtpa.h"
#include "fs_param_adapt.h"
#include "fs_pll.h"
#include "fs_polarity.h"
#include "fs_pwm5.h"
#include "fs_smo.h"
#include "fs_speed_ctrl.h"
#include "fs_svpwm.h"
#include "fs_swvi.h"
#include "fs_vsd.h"
#include "fs_types.h"

/* Compile-time options: a firmware leaves out what it does not use by
 * defining one to 0 for every file of csrc/control (-DFS_WITH_IMC=0); the
 * code and the sub-blocks behind it are then not linked, and fs_drive_init
 * refuses a configuration that needs them (FS_ERR_MODE, drv->fail naming
 * phases, angle_source or converter). The structs keep every field, so a
 * configuration is the same bytes whatever the options.
 *   FS_WITH_IMC         the indirect matrix converter (fs_imc.h)
 *   FS_WITH_FIVE_PHASE  five phases (fs_vsd.h, fs_pwm5.h)
 *   FS_WITH_SWVI        square-wave injection (fs_swvi.h)
 *   FS_WITH_IDENT       the identification mode (fs_ident.h; mode refused)
 *   FS_WITH_ADAPT       the online R_s and psi_f correction (fs_param_adapt.h; adapt refused)
 *   FS_WITH_DTCOMP      dead-time compensation on the predicted current (fs_dtcomp.h; dt_predict refused)
 *   FS_WITH_FLUXMAP     a flux map in the controller (fs_fluxmap.h, fs_fwmap.h; map refused): 4.7 kB of
 *                       flash at -O2, 900 B of config, 2.2 kB of RAM (the flux weakening's table)
 *   FS_WITH_MOTION_TEST polarity by a bounded motion (fs_motion_test.h; motion refused)
 *   FS_WITH_IF_START    the I/f start into the back-EMF observer (fs_if_start.h; i_start refused)
 * A three-phase inverter drive on the blend with flux weakening needs only
 * FS_WITH_DTCOMP (the scenarios' default while the drive injects: the
 * carrier's current crosses zero within the period; without a carrier
 * fs_dtcomp_step computes the usual compensation, which is then the same): a commissioning
 * build keeps FS_WITH_IDENT, a production build leaves it out; one whose machine's
 * polarity pulses decide (its d axis saturates) leaves out the starts that turn the rotor,
 * FS_WITH_MOTION_TEST and FS_WITH_IF_START (3,380 B of flash at -O2 with their glue: the
 * blended image 35,424 B with them, 32,044 B without, bench/firmware.py). */
#ifndef FS_WITH_IMC
#define FS_WITH_IMC 1
#endif
#ifndef FS_WITH_FIVE_PHASE
#define FS_WITH_FIVE_PHASE 1
#endif
#ifndef FS_WITH_SWVI
#define FS_WITH_SWVI 1
#endif
#ifndef FS_WITH_IDENT
#define FS_WITH_IDENT 1
#endif
#ifndef FS_WITH_ADAPT
#define FS_WITH_ADAPT 1
#endif
#ifndef FS_WITH_DTCOMP
#define FS_WITH_DTCOMP 1
#endif
#ifndef FS_WITH_MOTION_TEST
#define FS_WITH_MOTION_TEST 1
#endif
#ifndef FS_WITH_IF_START
#define FS_WITH_IF_START 1
#endif

typedef enum {
    FS_MODE_OFF = 0,         /* duties 0.5, zero voltage */
    FS_MODE_VOLTAGE_DQ = 1,  /* u_d_ref, u_q_ref in a frame at w_e_ref */
    FS_MODE_VF = 2,          /* |u| = vf_boost + vf_gain |w_e_ref| on the q axis of that frame */
    FS_MODE_CURRENT = 3,     /* i_d_ref, i_q_ref */
    FS_MODE_SPEED = 4,       /* w_m_ref -> torque -> MTPA -> currents */
    FS_MODE_IDENTIFY = 5     /* self-commissioning (fs_ident.h): the machine's fields are not read */
} fs_drive_mode;

typedef enum {
    FS_ANGLE_ENCODER = 0,    /* encoder angle, speed from a PLL on it */
    FS_ANGLE_EXTERNAL = 1,   /* theta_e_ext and w_e_ext from the input */
    FS_ANGLE_SMO = 2,        /* extended-EMF sliding-mode observer (encoder until handed over) */
    FS_ANGLE_HFI = 3,        /* rotating HF voltage injection (yang2022 sec. 3) */
    FS_ANGLE_BLEND = 4,      /* SMO and HFI blended by speed (yang2022 sec. 4) */
    FS_ANGLE_SWVI = 5        /* square-wave HF injection, filterless (yu2022); current and speed modes */
} fs_angle_source;

typedef enum {
    FS_CONV_VSI = 0,         /* two-level voltage-source inverter on a dc link */
    FS_CONV_IMC = 1          /* indirect matrix converter (zou2021), three phases */
} fs_converter;

typedef enum {
    FS_PHASE_RUN = 0,        /* the loops on the configured angle source */
    FS_PHASE_START = 1,      /* I/f start: open-loop frame, waiting for the observer */
    FS_PHASE_POLARITY = 2,   /* magnet polarity detection: d-current pulses, i_q = 0 */
    FS_PHASE_RECOVER = 3,    /* lock lost: zero current while the estimators settle (fs_drive_start.c) */
    FS_PHASE_HALT = 4        /* refused to go on (fs_drive_out.fault): zero voltage, no injection (last: fs_drive.c
                                tells RECOVER and HALT from the rest with one comparison) */
} fs_drive_phase;

/* Why the drive refused to go on (fs_drive_out.fault), held from then on;
 * the caller must stop the inverter and report it. */
typedef enum {
    FS_FAULT_NONE = 0,
    FS_FAULT_POLARITY = 1,   /* polarity detection found no margin up to its largest pulse (fs_polarity.h), or the
                                motion test no turn, or too much noise or motion to decide (fs_motion_test.h) */
    FS_FAULT_LOCK = 2,       /* lock lost and not re-acquired: the retries spent, or none possible (fs_drive_protect.h) */
    FS_FAULT_OVERSPEED = 3,  /* the speed passed w_over (fs_drive_protect.h) */
    FS_FAULT_START = 4       /* the I/f start waited t_handover at w_handover without the observer agreeing */
} fs_drive_fault;

/* The operating stage, traced: where the drive is in its sequence
 * polarity -> injection -> blend -> back-EMF observer -> flux weakening and
 * back down (sensorless from standstill), each transition a change of this
 * value. It follows the phase, the blending weight and the flux-weakening
 * current (entered below -2 % of i_max, left above -1 %: hysteresis). */
typedef enum {
    FS_STAGE_OPEN = 0,           /* off, or an open-loop voltage mode */
    FS_STAGE_SENSOR = 1,         /* the loops on the encoder or an external angle */
    FS_STAGE_POLARITY = 2,
    FS_STAGE_START = 3,          /* I/f start */
    FS_STAGE_INJECTION = 4,      /* an injection estimator alone (g_w = 0) */
    FS_STAGE_BLEND = 5,          /* 0 < g_w < 1 */
    FS_STAGE_BACKEMF = 6,        /* the sliding-mode observer alone */
    FS_STAGE_FLUX_WEAKENING = 7, /* running with the flux-weakening d current */
    FS_STAGE_RECOVERY = 8        /* FS_PHASE_RECOVER */
} fs_drive_stage;

typedef struct {
    /* sizeof(fs_drive_config) as the writer of this configuration saw it:
     * `fullspeed export` and the simulator set it, and fs_drive_init refuses
     * a configuration whose size differs from the library's (a header and a
     * library from different versions); 0: not checked (hand-written code) */
    unsigned int config_size;
    int phases;              /* 3, or 5: the fundamental plane of the VSD, nearest-four-vector PWM */
    int mode;                /* fs_drive_mode */
    int angle_source;        /* fs_angle_source */
    float Ts;                /* control (sampling) period, s */
    float T_pwm;             /* carrier period, s (Ts or 2 Ts) */
    float delay;             /* computation delay in control periods: 1 or 0 */
    /* the machine as the controller knows it: L_d, L_q, psi_f for the
     * decoupling, the loops' design and the observers; a flux map's
     * (fullspeed.design.magnetics): psi_f at zero current and the secant inductances
     * at the MTPA point of rated current */
    float R_s;               /* stator resistance, ohm */
    float L_d, L_q;          /* d and q inductances, H */
    float psi_f;             /* the magnet's flux linkage, Wb (peak phase) */
    /* the incremental inductances the injection sees (HFI and blend; 0:
     * L_d, L_q above); a flux map's at half the rated current on its MTPA
     * locus */
    float L_d_hf, L_q_hf;    /* the injection's incremental inductances, H */
    int pole_pairs;
    float J;                 /* inertia, kg m^2 */
    float B;                 /* viscous friction, N m s/rad */
    /* limits */
    float i_max;             /* A peak */
    float T_max;             /* N m */
    /* design bandwidths, rad/s */
    float bw_current, bw_speed, bw_pll;
    /* dead-time compensation: the dead time to compensate (0: off; below
     * T_pwm / 2) and the current below which the compensation ramps linearly
     * to zero */
    float t_dead_comp, i_dead_band;
    /* 1: the dead-time compensation takes each edge's sign from the current
     * predicted there (fs_dtcomp.h); 0: from the sampled current */
    int dt_predict;
    /* five phases: x-y current control (fs_xyctrl.h) at this bandwidth,
     * rad/s, with the third-harmonic plane's L_d3, L_q3, psi_f3 (0: off,
     * the x-y voltage left at zero by the modulator) */
    float bw_xy, L_d3, L_q3, psi_f3;
    /* V/f: volts per electrical rad/s and boost volts */
    float vf_gain, vf_boost;
    /* the estimator, for FS_ANGLE_SMO (Ts and machine fields are taken from above) */
    fs_smo_config smo;
    /* flux weakening in speed mode (zou2021 PART_1, fs_fw.h): the top
     * electrical speed of eq. (31), rad/s (0: off), the gain on its beta (the
     * loop's dc gain at the top speed; the paper: 1), the low-pass cutoff of
     * eq. (30), rad/s, and what the current regulators do with the over-
     * modulation excess: fw_hold 0 wind it back to the realised voltage (their
     * anti-windup), 1 keep it (fs_fw_hold, the paper's eq. (26); use the
     * internal-model regulators, cc_internal_model, fs_fw.h says why).
     * Wound back, gain 0 is 50 and cutoff 0 is designed as
     *   gain x cutoff = min(bw_current / 4, w_e,max / 2).
     * The first bound keeps the loop below the current loop. The second
     * bounds a fast path eq. (26) leaves out: a step in i_d* kicks u_d* by
     * about L bw_current, the voltage limit then cuts u_q (by |u_d|/u_max of
     * the kick) and dv_q grows, which deepens i_d* again. That positive loop
     * peaks at gain x cutoff x |u_d|/u_max / w_e,max and must stay below 1;
     * on zou2021's 150 V bench (w_e,max 126 rad/s) a cutoff of 750 rad/s
     * limit-cycled at 20-30 Hz. With gain 50 the standing current error this
     * variant leaves (fs_fw.h) is a fiftieth of the paper's gain's.
     * Held, the loop's integral gain at the top speed is K = gain bw_current
     * (fs_fw.h); gain 0 is designed as K = min(bw_current / 4, 1.5 w_e,max)
     * and cutoff 0 as K (gain x bw_current), the paper's own pairing (w_c =
     * K = bw_current at gain 1), zeta 0.5. The first bound keeps the loop
     * below the current loop: at the paper's gain 1 it crosses over at the
     * current loop's bandwidth and, with the period of delay, oscillates
     * (zou2021: i_d 7-10 A peak to peak at 1500-1750 rpm, 1750 rpm at
     * 10 N m not held). The second keeps its natural frequency K a quarter
     * of the over-modulation's first harmonic in the rotor frame, 6 w_e: on
     * the 150 V bench (w_e,max 126 rad/s) K = 750 rad/s met it at 120 Hz and
     * i_d swung 5 A peak to peak (0.3 A at K = 188). */
    float fw_w_e_max, fw_gain, fw_cutoff;
    int fw_hold;
    /* loss-of-lock monitor (fs_lock.h) while the loops run sensorless: the
     * time, s, the estimator in use may spend off track, net, before lock
     * counts as lost (0: no monitor). The residual: the sliding-mode
     * observer's current error over twice its boundary layer and its PLL
     * error over sin 30 deg (once valid); the injection estimator's error
     * over 15 deg (once settled); the square wave's PLL error over 30 deg
     * (it has no recovery: lock_recover is refused); in the blend, those
     * whose weight is not 0, and while the SMO is valid, its disagreement
     * with the blended angle over 45 deg (an injection estimate that
     * slipped while the rotor was thrown beyond the injection's speed
     * range); and, except with the square wave, the checks that do not
     * trust the estimator (fs_monitor.h: the back-EMF's direction and its
     * turn in the loops' frame, the load their motion implies and the sign
     * of its answer to the torque they command, the current loops' error;
     * their angle jumping beyond their speed latches at once), low-passed
     * over lock_time / 4 as well. */
    float lock_time;
    /* recovery from a loss of lock (lock_recover = 1; else the monitor
     * latches lock_lost and the drive goes on): the flying restart, the
     * start sequence again, or the halt with FS_FAULT_LOCK, by the speed the
     * back-EMF says (fs_drive_protect.h); t_recover, s, the zero-current
     * wait; after lock_retries recoveries the next loss halts. */
    int lock_recover;
    float t_recover;
    int lock_retries;
    /* the overspeed stop (fs_drive_protect.h): above this electrical speed,
     * rad/s, the drive halts with FS_FAULT_OVERSPEED (0: none) */
    float w_over;
    /* sensorless start (speed mode, FS_ANGLE_SMO, sensorless from standstill):
     * I/f, a current of i_start on the d axis of a frame accelerated at a_start
     * (el. rad/s^2) up to w_handover (el. rad/s), where the loops take the
     * observer's angle and speed. i_start = 0: off (the encoder starts). */
    float i_start, a_start, w_handover;
    /* injection (FS_ANGLE_HFI, FS_ANGLE_BLEND): Ts, delay, L_d, L_q and the
     * observer's Ts, J, B, pole_pairs are taken from above */
    fs_hfi_config hfi;
    /* FS_ANGLE_BLEND: the band (w_lower, w_upper) and the filtering observer's
     * bandwidth (the rest as for hfi.obs); above w_inject_max (el. rad/s; 0:
     * never) the injection stops, and resumes below 0.9 w_inject_max, which
     * must be >= w_upper */
    fs_blend_config blend;
    float w_inject_max;
    /* polarity detection when sensorless from the first step (i_pulse 0: none;
     * Ts taken from above; i_pulse_max 0: i_max less the carrier's peak; the
     * carrier's period and filter bandwidth taken from hfi). Without a margin
     * at its largest pulse the drive halts with FS_FAULT_POLARITY. */
    fs_polarity_config polarity;
    /* square-wave injection (FS_ANGLE_SWVI): Ts, delay, L_d, L_q are taken
     * from above; delay must be 0 or 1 */
    fs_swvi_config swvi;
    /* explicit PI gains, e.g. a paper's (all 0: designed from bw_current and
     * bw_speed): current loop per axis, V/A and V/(A s); speed loop,
     * N m s/rad and N m/rad */
    float k_p_d, k_i_d, k_p_q, k_i_q, k_p_w, k_i_w;
    /* without explicit current gains, 1: the current regulators by internal
     * model (fs_current_ctrl.h; zou2021's, its sec. 4.2 and 5.1); 0: by pole
     * placement */
    int cc_internal_model;
    /* the converter (fs_converter). An indirect matrix converter takes the
     * highest modulation region it may use (fs_imc_region), the input
     * frequency (rad/s: the sampled input voltage is turned to the middle of
     * the period it acts in) and, in the over-modulation II region, its
     * depth angle either from PART_2 (imc_depth = 1: speed mode with flux
     * weakening; I_lim, and the nominal input amplitude V_im for the gains'
     * design) or from the demanded transfer ratio (imc_depth = 0) */
    int converter;
    int imc_region;
    float imc_w_grid;
    int imc_depth;
    float imc_i_lim, imc_V_im;
    /* online correction of R_s and psi_f (fs_param_adapt.h), learnt while
     * the loops run sensorless (rotating injection, SMO, blend); the SMO's
     * model and the current loop's feed-forward take the estimates. T_f 0:
     * off; Ts, R_s, L_d, psi_f and i_max are taken from above, w_e_max 0
     * from smo.w_e_max */
    fs_param_adapt_config adapt;
    /* speed mode while injecting: the speed loop's torque changes at most
     * T_slew N m/s (0: no limit). The observers feed the torque forward on
     * J; one the shaft does not follow (a load machine, a vehicle) is an
     * unknown load to them, and this bounds how fast it can come
     * (fullspeed.design: the ramp the injection's observer follows within
     * 5 el.deg). */
    float T_slew;
    /* the machine's flux map (fs_fluxmap.h; di_d = 0: none, the model of
     * L_d, L_q, psi_f above), resampled by fullspeed.design.magnetics. With
     * it: the MTPA locus is searched on the map at init (fs_mtpa.h); each
     * step evaluates it at the last current reference, and the back-EMF
     * observer takes its q secant inductance and active flux
     * (fs_smo_set_model), the observers' torque feed-forward and the
     * monitor its torque; with flux weakening, the speed mode's current
     * references come from fs_fwmap.h above base speed (its own trim on
     * the voltage in place of fs_fw.h's voltage-error feedback), and above
     * the blending band the blend follows the back-EMF observer's tracker
     * (fs_drive.c says why). Held in the config, not pointed to, so that the
     * config has no pointer: the same bytes on the host and the target,
     * and an export carries the map */
    fs_fluxmap_table map;
    /* 1: the map only plans the flux weakening (fs_fwmap.h): a machine
     * given by L_d, L_q, psi_f, whose map is the one those make; the
     * current loops, MTPA, observers and monitor stay on L_d, L_q, psi_f */
    int map_fw_only;
    /* FS_MODE_IDENTIFY (three phases, inverter): Ts, delay, pole_pairs and
     * i_max are taken from above */
    fs_ident_config ident;
    /* The start chosen by the machine (fullspeed.design.start), after the
     * fields above so that their places stay where the step reads them.
     * Polarity by a bounded motion (fs_motion_test.h) instead of the pulses
     * when motion.i_push > 0 (polarity.i_pulse is then 0; Ts taken from
     * above; the push at most i_max less the carrier's peak). The I/f start
     * (i_start > 0, fs_if_start.h): its damping's virtual resistance r_damp
     * (ohm, 0: none) centred on the rotor's swing at w_swing (rad/s), the
     * longest wait at w_handover for the observer, t_handover (s, 0: no
     * limit; then FS_FAULT_START), and w_restart (el. rad/s, 0: never):
     * running on the observer below it, with the reference below it too, the
     * loops return to the I/f frame (the observer is not trusted at the
     * speeds it has to pass through: a reversal) and hand over again at
     * w_handover (> w_restart). */
    fs_motion_test_config motion;
    float r_damp, w_swing, t_handover, w_restart;
} fs_drive_config;

typedef struct {
    float i_ph[FS_PHASES_MAX];   /* sampled phase currents, A (the first `phases`) */
    float u_dc;              /* sampled dc-link voltage, V */
    float u_in[3];           /* matrix converter: sampled input phase voltages, V */
    float theta_m_enc;       /* encoder mechanical angle, rad */
    float theta_e_ext, w_e_ext;  /* external angle source, rad, rad/s */
    /* references */
    float w_m_ref;           /* rad/s mechanical, speed mode */
    float i_d_ref, i_q_ref;  /* A, current mode */
    float u_d_ref, u_q_ref;  /* V, voltage mode */
    float w_e_ref;           /* rad/s electrical, frame speed of the open-loop modes */
    int sensorless;          /* 1: the loops use the estimator; 0: the encoder (estimator runs alongside) */
} fs_drive_in;

typedef struct {
    float duty[FS_PHASES_MAX];   /* for the next update instant (the first `phases`) */
    /* telemetry */
    float theta_e, w_e;      /* angle and speed used by the loops */
    float i_d, i_q;          /* measured, in the controller frame */
    float i_d_ref, i_q_ref;
    float T_ref;
    float u_d, u_q;          /* realised voltage reference in the controller frame */
    bool over_modulation;
    float theta_est, w_est;  /* the estimator's angle and electrical speed, used or not */
    bool est_valid;
    int phase;               /* fs_drive_phase */
    float i_d_fw;            /* d-current added by flux weakening, A */
    float g_w;               /* blending weight, eq. (28): 1 = SMO, 0 = HFI */
    bool injecting;          /* the HF voltage is on */
    float i_hf_d, i_hf_q;    /* square-wave injection: the HF current at the last peak, signed, eq. (8), A */
    fs_imc_rect rect;        /* matrix converter: the rectifier stage's intervals for the next update */
    float alpha;             /* matrix converter: the depth angle they use, rad */
    float lock_resid;        /* the loss-of-lock residual (<= 1: on track), 0 when not monitored */
    bool lock_lost;          /* latched by the monitor (fs_lock.h); with recovery, once the retries are spent */
    int stage;               /* fs_drive_stage */
    int recoveries;          /* recoveries begun so far */
    int fault;               /* fs_drive_fault: the drive refused to go on (duties 0.5 from then on) */
    int ident_step;          /* FS_MODE_IDENTIFY: the step it is in (fs_ident_stepid); the result is in fs_drive.ident */
} fs_drive_out;

/* The members every step reads come first: a Cortex-M4F's vldr/vstr reach
 * 1020 B from a base register, and the blocks past that cost an address
 * computation per access (the blended step, bench/pil.py: 2,738.8 -> 2,632.9
 * instructions mean with the monitor, dead-time compensation, lock, the
 * drive's own state, the SMO and the blend ahead of the 1.6 KB config). */
typedef struct {
    fs_monitor mon;          /* the checks that do not trust the estimator (with lock_time > 0) */
    fs_dtcomp dtc;           /* when cfg.dt_predict and t_dead_comp > 0 */
    fs_lock lock;
    float i_hf;              /* the rotating carrier current's peak, A: i_max less it bounds the fundamental */
    float lock_a;            /* the residual's low-pass pole */
    float lock_ri, lock_es, lock_eh;   /* low-passed: SMO current error / delta, SMO PLL error, injection error */
    float t_quiet;           /* s: the injection's error joins the lock's residual once this has run out: after
                                polarity detection, whose pulses or push disturbed the estimate, polarity.t_lock */
    float lock_ex;           /* low-passed: |SMO angle - blended angle| while the SMO is valid, rad */
    float w_over;            /* the overspeed stop on the loops' speed, el. rad/s: cfg.w_over; FS_DRIVE_NO_LIMIT
                                without one and during a recovery's zero-current wait (fs_drive_protect.h) */
    int stage;               /* fs_drive_stage */
    int recoveries;
    float t_left;            /* s left in FS_PHASE_RECOVER */
    float alpha;             /* its last output, rad */
    int phase;               /* fs_drive_phase */
    float theta_ol;          /* open-loop frame angle */
    bool pll_started;        /* the encoder's PLL has its first reading */
    bool pll_seeded;         /* and its speed from the second (drive_sensor_angle) */
    bool est_started;        /* the injection estimators have seen their first step */
    bool injecting;          /* the HF voltage is on (fading in or out included) */
    bool inject_on;          /* the injection is wanted (the amplitude's target) */
    bool has_map;            /* cfg.map holds a flux map (fs_drive.map): the machine's, or the flux weakening's only */
    bool fw_map_on;          /* this step's references are the map's flux weakening (fs_fwmap.h) */
    bool follows;            /* the blend is the back-EMF tracker's own above its band (drive_injection_step) */
    float T_ff;              /* N m: torque of the last step's current reference (the observers' feed-forward) */
    float T_slew;            /* N m: the speed loop's last torque reference, after the slew (its anchor) */
    float k_T;               /* N m/A: the torque constant phases/2 p (drive_torque_k) */
    fs_ab u_hist[2];         /* realised fundamental voltage computed 1 and 2 steps ago */
    fs_smo smo;
    fs_blend blend;
    fs_drive_config cfg;
    fs_current_ctrl cc;
    fs_speed_ctrl sc;
    fs_mtpa mtpa;
    fs_fw fw;
    fs_hfi hfi;
    fs_pll pll;              /* speed from the encoder */
    float dd_dead;           /* t_dead_comp / T_pwm: the duty the dead time takes (the sampled-sign compensation; the
                                blend's predicted one has its own), past the hot members' 1 KB */
    fs_polarity pol;
    fs_swvi sw;
    fs_imc_depth depth;      /* matrix converter, PART_2 */
    fs_param_adapt adapt;    /* when cfg.adapt.T_f > 0 */
    fs_xyctrl xy;            /* when cfg.bw_xy > 0 */
    /* square-wave injection: the fundamental voltage acting over the present
     * window and the one computed for the next; the loops' last outputs */
    fs_ab u_ff_hold, u_ff_next;
    fs_drive_out held;
    fs_ident ident;          /* FS_MODE_IDENTIFY */
    int fault;               /* fs_drive_fault, held in FS_PHASE_HALT */
    float e_rec;             /* FS_PHASE_RECOVER: the back-EMF's magnitude, low-passed, V (fs_drive_protect.h) */
    fs_fluxmap map;          /* on cfg.map, when has_map */
    fs_fwmap fwm;            /* with the map and flux weakening: the references within the voltage limit */
    /* with the map (drive_map_step): its point at the last step's current, for the back-EMF observer's transient
     * (fs_smo_transient; past the hot members' 1 KB, as map), and whether to take it (not after injecting) */
    fs_fluxmap_point smo_at;
    bool smo_transient;
    float smo_k_speed;         /* ... and the weight of its speed innovation there, 1 - g (fs_smo_speed) */
    /* after a refused init, the config field or sub-block at fault, as a
     * string literal ("smo.bw_pll", "i_max", "hfi"; fs_status_str tells
     * why); NULL after a successful one */
    const char *fail;
    /* the start (fs_drive_start.c), past everything the run reads */
    fs_motion_test mt;       /* polarity by motion (cfg.motion.i_push > 0) */
    float mt_ff;             /* N m: the feed-forward of the motion test's push taken back out of the observers' loads */
    bool hfi_aligned;        /* the polarity stage's estimate set on the saliency's axis from the carrier (fs_drive_start.c) */
    fs_if_start ifs;         /* the I/f frame (cfg.i_start > 0) */
} fs_drive;

/* Every float field is refused when not finite (naming it), each field out of
 * its range, and a sub-block's config by the sub-block's own init. */
fs_status fs_drive_init(fs_drive *drv, const fs_drive_config *cfg);
void fs_drive_reset(fs_drive *drv);
void fs_drive_step(fs_drive *drv, const fs_drive_in *in, fs_drive_out *out);

#endif /* FS_DRIVE_H */
