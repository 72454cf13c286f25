/* The closed-loop runner: plant, inverter, sampling, delay and the drive.
 *
 * Timing: the control period Ts is the carrier period (single sampling and
 * update, at the carrier peak) or half of it (double sampling and update, at
 * peak and valley). At each sampling instant the currents and the encoder are
 * sampled (with quantization and optional Gaussian noise), the drive step
 * computes new duties, and they take effect at the next update instant (one
 * control period of computation delay) or, with the delay switched off, at
 * once. Python advances the simulation in chunks; every `decimation`-th
 * sample is written as a row of FS_CH_N channels into a caller's buffer.
 *
 * Converter: the two-level inverter on a fixed dc link, or an indirect
 * matrix converter (zou2021): the grid and LC filter of fs_grid.h, the
 * rectifier stage's two intervals of each period in turn (fs_imc.h), and in
 * each interval the inverter stage averaged over its vector sequence: the
 * pole voltages are the duties times the interval's line voltage v_pn and
 * the dc-link current is sum(duty i), drawn from the two input phases on
 * the rails. The plant and the filter are integrated together, so the
 * input current is built from the switching functions and its spectrum is
 * the converter's. With the module's devices (inverter.dev) the rectifier's
 * path (two bidirectional switches, each a transistor and a diode in
 * series) drops its voltage from v_pn, and each inverter-stage leg its
 * devices' drop; with a dead time each leg loses it once per interval, as
 * the averaged inverter does per period. Neglected: the switching ripple
 * inside an interval and the rectifier's commutation (it switches at zero
 * dc-link current, in the inverter's zero vectors: no switching loss);
 * single sampling.
 *
 * Losses (plant.losses): the converter's meters run with the machine's
 * (fs_pmsm.h). E_DC is the energy the converter takes from its source, the
 * inverter's dc link (u_dc sum s_k i_k, fs_inverter.h) or the matrix
 * converter's input capacitors (v_pn i_dc); E_COND its devices' conduction
 * loss (the matrix converter's inverter stage), E_RECT the rectifier's,
 * E_SW the commutation energies (fs_losses.h; each leg's at each edge, the
 * matrix converter's stage once up and down per interval, at the interval's
 * start). The source supplies E_SW too: the matrix converter draws it from
 * its filter as a constant power over the interval. So, to the integrator's
 * precision, E_DC = E_IN + E_COND + E_RECT + E_SW, and E_AIRGAP = E_FE +
 * E_MECH + E_SHAFT + the kinetic energy's change.
 */
#ifndef FS_SIM_H
#define FS_SIM_H

#include <stdint.h>
#include "../control/fs_drive.h"
#include "../plant/fs_grid.h"
#include "../plant/fs_inverter.h"
#include "../plant/fs_pmsm.h"
#include "../plant/fs_thermal.h"

/* A piecewise-linear profile y(t), held constant outside [t[0], t[n-1]]. */
typedef struct {
    int n;
    const double *t;
    const double *y;
} fs_profile;

typedef enum { FS_SAMPLING_SINGLE = 0, FS_SAMPLING_DOUBLE = 1 } fs_sampling;

/* Faults of the simulated drive's hardware (all zero: none). Each acts from
 * its time on. The dc link's sag or step is the profile u_dc_scale; a load
 * impact is a T_load profile; ADC saturation is a current beyond adc_range. */
typedef struct {
    double t_sensor;          /* s: the current-sensor errors below act from here */
    double i_offset[FS_INV_MAX_LEGS];   /* A, added to each phase's sensed current */
    double i_gain[FS_INV_MAX_LEGS];     /* relative gain error of each phase's sensor (0.1: reads 10 % high) */
    int open_phase;           /* 0: none; 1, 2, 3: phase a, b or c opens (three phases, inverter) */
    double t_open;            /* s */
    double t_encoder_stop;    /* s, > 0: the encoder's reading freezes here; 0: never */
} fs_fault_config;

/* plant.phases, inverter.phases and drive.phases must agree (3 or 5). */
typedef struct {
    fs_pmsm_config plant;
    fs_thermal_config thermal;  /* enabled: R_s and the magnet follow the winding's and magnets' temperatures */
    fs_inverter_config inverter;
    int converter;            /* fs_converter; must equal drive.converter */
    fs_grid_config grid;      /* the matrix converter's input side */
    /* timing */
    int sampling;             /* fs_sampling */
    int delay;                /* 1: duties act one control period later; 0: at once */
    double h_max;             /* longest integration step, s */
    /* sensors */
    int adc_bits;             /* 0: no quantization */
    double adc_range;         /* A, full scale +-adc_range: the reading saturates beyond (<= 0: no limit) */
    double noise_i;           /* A, standard deviation of current noise */
    int encoder_bits;         /* 0: exact encoder; else counts per mechanical turn = 2^bits */
    uint64_t seed;
    /* protection */
    double i_trip;            /* A, phase-current trip level (<= 0: none) */
    int lock_stop;            /* 1: stop with FS_STOP_LOSS_OF_LOCK when the drive reports lock lost */
    /* initial state */
    double theta_m0, w_m0;    /* rad, rad/s */
    fs_fault_config fault;
    /* the controller */
    fs_drive_config drive;
    /* profiles (copied by fs_sim_create) */
    fs_profile w_m_ref, i_d_ref, i_q_ref, u_d_ref, u_q_ref, w_e_ref;
    fs_profile T_load, w_load;
    fs_profile sensorless;    /* > 0.5: the loops use the estimator */
    fs_profile u_dc_scale;    /* the dc link relative to inverter.u_dc (a sag, a step); n = 0: 1 */
    int decimation;           /* record every n-th sample */
} fs_sim_config;

/* Trace channels, one row per recorded sample (SI units, electrical angles). */
enum {
    FS_CH_T = 0,
    FS_CH_THETA_E,            /* true electrical angle, wrapped */
    FS_CH_W_M,                /* true mechanical speed */
    FS_CH_PSI_D, FS_CH_PSI_Q,
    FS_CH_I_D, FS_CH_I_Q,     /* true, rotor frame */
    FS_CH_I_A, FS_CH_I_B, FS_CH_I_C,          /* the first three phases */
    FS_CH_T_E, FS_CH_T_L,     /* electromagnetic torque, shaft load torque */
    FS_CH_U_D, FS_CH_U_Q,     /* mean terminal voltage over the last period, rotor frame */
    FS_CH_DUTY_A, FS_CH_DUTY_B, FS_CH_DUTY_C,   /* duties computed at this sample (first three legs) */
    FS_CH_W_M_REF, FS_CH_I_D_REF, FS_CH_I_Q_REF, FS_CH_T_REF,
    FS_CH_I_D_HAT, FS_CH_I_Q_HAT,               /* currents in the controller's frame */
    FS_CH_U_D_REF, FS_CH_U_Q_REF,               /* realised reference, controller frame */
    FS_CH_THETA_HAT, FS_CH_W_M_HAT,             /* angle and speed used by the controller */
    FS_CH_THETA_ERR,                            /* true minus used angle, wrapped */
    FS_CH_OVERMOD,
    FS_CH_E_IN, FS_CH_E_CU, FS_CH_E_AIRGAP, FS_CH_W_MAG,  /* J; W_MAG is m/2 (W(psi) + W3), fs_pmsm_energy */
    FS_CH_THETA_EST, FS_CH_W_M_EST, FS_CH_EST_VALID,      /* the estimator's output, used or not */
    FS_CH_EST_ERR,                                        /* true minus estimated angle, wrapped */
    FS_CH_PHASE,              /* fs_drive_phase: 1 while the I/f start runs, 2 polarity detection */
    FS_CH_I_D_FW,             /* d-current added by flux weakening */
    FS_CH_G_W,                /* blending weight: 1 SMO, 0 HFI */
    FS_CH_INJECT,             /* 1 while the HF voltage is injected */
    FS_CH_I_D3, FS_CH_I_Q3,   /* true third-harmonic currents, d3-q3 frame (0 for three phases) */
    FS_CH_I_HF_D, FS_CH_I_HF_Q,   /* square-wave injection: HF current at the last peak, eq. (8) */
    /* matrix converter (0 for the inverter): means over the last period of
     * the grid current of phase a, the dc link and the output line voltage
     * u_A - u_B; the depth angle computed at this sample; the grid's energy
     * meters (fs_grid.h) and the filter's stored energy, J */
    FS_CH_I_GRID_A, FS_CH_V_PN, FS_CH_U_AB, FS_CH_ALPHA,
    FS_CH_E_GRID, FS_CH_E_RF, FS_CH_W_FILTER,
    FS_CH_LOCK_RESID, FS_CH_LOCK_LOST,   /* the drive's loss-of-lock residual and flag (fs_lock.h) */
    FS_CH_STAGE, FS_CH_RECOVERIES,       /* its operating stage (fs_drive_stage) and recoveries begun */
    FS_CH_U_DC,               /* the dc link at this sample, V (the inverter's; the matrix converter's mean v_pn) */
    /* the thermal model (fs_thermal.h): winding and magnet temperatures,
     * degC (0 without one), and the plant's true R_s and open-circuit
     * magnet flux (psi_d at zero current), ohm and Wb */
    FS_CH_T_WINDING, FS_CH_T_MAGNET, FS_CH_R_S_TRUE, FS_CH_PSI_F_TRUE,
    FS_CH_R_S_HAT, FS_CH_PSI_F_HAT,   /* the controller's R_s and psi_f (online correction, fs_param_adapt.h) */
    /* the loss meters (plant.losses; 0 without), J */
    FS_CH_E_DC, FS_CH_E_COND, FS_CH_E_RECT, FS_CH_E_SW,
    FS_CH_E_FE, FS_CH_E_MECH, FS_CH_E_SHAFT,
    FS_CH_N
};

typedef enum {
    FS_RUN_DONE = 0,          /* reached t_end */
    FS_RUN_BUFFER_FULL = 1,   /* trace buffer full before t_end: call again */
    FS_STOP_NAN = 2,          /* a state became NaN or infinite */
    FS_STOP_OVERCURRENT = 3,  /* a phase current exceeded i_trip */
    FS_STOP_LOSS_OF_LOCK = 4, /* an estimator lost track of the rotor (and, with recovery, was not re-acquired) */
    FS_STOP_POLARITY = 5,     /* the drive could not determine the magnet's polarity and refused to start */
    FS_STOP_OVERSPEED = 6,    /* the drive halted at its overspeed limit (fs_drive_protect.h) */
    FS_STOP_START = 7,        /* the I/f start never handed over to the observer (fs_drive FS_FAULT_START) */
    FS_RUN_ERR_NULL = -1,     /* sim or rows (or trace, with max_rows > 0) is NULL: nothing run */
    FS_RUN_ERR_ORDER = -2,    /* fs_sim_actuate without an fs_sim_sample before it: nothing run */
    FS_RUN_ERR_STRIDE = -3    /* fs_sim_run_cols with a stride below 1 or max_rows: nothing run */
} fs_run_status;

typedef struct fs_sim fs_sim;

/* Creates a simulation; on error (cfg NULL included) returns NULL and writes
 * a message naming the field into err (when err is not NULL). */
fs_sim *fs_sim_create(const fs_sim_config *cfg, char *err, int err_len);
void fs_sim_destroy(fs_sim *sim);
/* Advances to t_end, writing at most max_rows rows of FS_CH_N doubles into
 * trace; *rows receives the count. Returns an fs_run_status. It runs until
 * fs_sim_step_count reaches fs_sim_steps(sim, t_end): fs_sim_run_steps. */
int fs_sim_run(fs_sim *sim, double t_end, double *trace, int max_rows, int *rows);
/* The same, to k_end control periods run in all (nothing when k_end <= fs_sim_step_count). */
int fs_sim_run_steps(fs_sim *sim, long long k_end, double *trace, int max_rows, int *rows);
/* fs_sim_run_steps with the trace column-major: channel c of the call's row
 * r at trace[c * stride + r] (stride >= max_rows: each channel's samples are
 * contiguous, as the Python front keeps them); FS_RUN_ERR_STRIDE else. */
int fs_sim_run_cols(fs_sim *sim, long long k_end, double *trace, long stride, int max_rows, int *rows);
/* The control periods a run from 0 to t takes: the nearest whole number,
 * ceil(t / Tc - 1/2), so that |n Tc - t| <= Tc / 2 (a remainder of exactly
 * half a period is not run); 0 for t <= Tc / 2 or NaN. One rule for
 * fs_sim_run and its callers, which count periods with it instead of
 * comparing times (a loop waiting for the time to reach t would wait for
 * ever when the remainder is under half a period). */
long long fs_sim_steps(const fs_sim *sim, double t);
/* The control periods run so far (fs_sim_time is this times Tc); -1 for a NULL sim. */
long long fs_sim_step_count(const fs_sim *sim);
/* Simulated time, s (NaN for a NULL sim, as the two below). */
double fs_sim_time(const fs_sim *sim);
/* Time of the stop, for a run that stopped (NaN otherwise). */
double fs_sim_stop_time(const fs_sim *sim);
/* First sample whose current reading saturated at +-adc_range (NaN: none yet). */
double fs_sim_adc_saturated_at(const fs_sim *sim);
/* The drive under simulation, to read its state (e.g. the polarity detection's margin, the identification's result). */
const fs_drive *fs_sim_drive(const fs_sim *sim);

/* Co-simulation: a master (csrc/fmu's FMU of the closed loop) in place of
 * the scenario's profiles. From now on profile `which` holds `value` (the
 * unit of its fs_sim_config profile) and `slope` (per second: the shaft
 * follows the load machine's speed w_load over the period with it; 0
 * elsewhere). Returns 0, or -1 for a NULL sim or an index out of range. */
typedef enum {
    FS_SIM_W_M_REF = 0, FS_SIM_I_D_REF, FS_SIM_I_Q_REF, FS_SIM_U_D_REF, FS_SIM_U_Q_REF, FS_SIM_W_E_REF,
    FS_SIM_T_LOAD, FS_SIM_W_LOAD, FS_SIM_SENSORLESS, FS_SIM_U_DC_SCALE, FS_SIM_PROFILES
} fs_sim_profile;
int fs_sim_hold(fs_sim *sim, int which, double value, double slope);

/* Co-simulation with the drive outside the runner (an FMU of it, a drive on
 * a bench), in place of fs_sim_run: call in turn fs_sim_sample, which
 * writes the inputs the drive gets at the next sampling instant and that
 * instant's time t, s, and fs_sim_actuate, which takes the duties (the
 * first `phases`; and the matrix converter's rectifier intervals, else
 * NULL) the drive computed from them and runs the plant over the period,
 * with the computation delay as configured. Both return FS_RUN_DONE or the
 * stop (NaN, overcurrent; FS_RUN_ERR_NULL, FS_RUN_ERR_ORDER). The runner's
 * own drive is not stepped, no trace is written and the drive's stops (lock,
 * polarity) are the caller's. */
int fs_sim_sample(fs_sim *sim, fs_drive_in *in, double *t);
int fs_sim_actuate(fs_sim *sim, const float *duty, const fs_imc_rect *rect);
/* The plant's channels of a trace row (FS_CH_*: time, angle, speed, fluxes,
 * currents, torques, the terminal voltage over the last period, meters, the
 * dc link, temperatures) at the present time, as the next sample records
 * them; the drive's channels are left as they are. */
void fs_sim_plant_row(fs_sim *sim, double *row);
/* The dc link over the last period: its voltage, V, and the mean current,
 * A, and power, W, drawn from it: the machine's input energy over the
 * period (exact, a state) plus the devices' conduction loss (u_on |i| +
 * r_on i^2 a leg, by the trapezoid over the period's ends); with the loss
 * meters (plant.losses) the source's own meter, devices and commutations in
 * it. NaN before the first period. */
void fs_sim_dc_link(fs_sim *sim, double *u_dc, double *i_dc, double *p_dc);

#endif /* FS_SIM_H */
