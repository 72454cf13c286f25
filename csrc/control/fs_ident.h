/* Self-commissioning: the drive measures the machine it is about to run.
 *
 * A sequence of steps, each run from the sampled currents and dc link alone
 * (no position sensor), each checking that its own measurement can be
 * trusted and saying why not instead of returning a number:
 *
 *   PROBE   voltage pulses on alpha, doubled until the current answers: a
 *           coarse inductance for the current loop's design (the pulse
 *           amplitude from i_max and Ts: the current may reach i_probe in
 *           n_p samples, u_p = L i_probe / (n_p Ts)).
 *   ALIGN   dc current on alpha, beta held at zero voltage (a short circuit
 *           there damps the rotor's swing by its own back-EMF): the magnet's
 *           d axis settles on alpha.
 *   LEVELS  dc current steps on the d axis at FS_IDENT_NLEV levels: the
 *           inverter's voltage error against current (dead time, device
 *           drops), fitted per leg as g(i) = u_e i / sqrt(i^2 + i_e^2), and
 *           R_s from the slope of the top three levels, where the error is
 *           flat (the slope cancels the inverter's offset).
 *   LDQ     an alternating HF voltage (a tenth of the sampling rate) on d
 *           at zero current, then on q at two d-axis bias currents that
 *           keep its legs' currents off zero (the dead time's error then
 *           constant): L from the response's reactance (exact for a
 *           sampled R-L branch with the computation delay), L_q's change
 *           with i_d and L_q at zero current by extrapolation; the cross
 *           response to the d carrier checks the alignment.
 *   SPIN    I/f: the current on the frame's d axis, the frame accelerated
 *           to w_spin (or to the speed where |u| reaches half the linear
 *           limit) in t_ramp.
 *   FLUX    zero current, the frame locked on the back-EMF by a PLL: at
 *           zero current the voltage is the EMF (R_s and L drop out),
 *           psi_f = |e| / |w|.
 *   ACCEL   i_q = i_acc in that frame: the acceleration of a known torque.
 *   COAST   zero current again: the deceleration by friction alone, over
 *           two halves (B and T_coulomb); J = T / (a_acc - a_coast).
 * and DONE (zero current held on the tracking frame) or FAILED.
 *
 * Where the design values come from: the probe's pulse from i_max and Ts
 * (doubled from 1 % of the link until the current answers); the current
 * loops' bandwidth from Ts (0.1/Ts), their gains from the probe's L, later
 * the measured R_s, L_d, L_q; the levels' settling from that bandwidth and
 * their windows from the noise (batch means); the carriers from i_max and
 * the impedance |R_s + j w_h L| at w_h = 2 pi / (10 Ts); the PLL from the
 * current loop and the spin's speed; the acceleration's current from a
 * first try, cut by four while the speed changes faster than the PLL can
 * follow (the mechanical time constant found on the way); the coast from
 * the acceleration's duration. Each constant's reason is beside it in
 * fs_ident.c.
 *
 * Three phases, float32, no heap, no globals. The instance holds the
 * result; fs_ident_step returns the stationary voltage reference the drive
 * modulates (within the linear range, so that it is realised).
 */
#ifndef FS_IDENT_H
#define FS_IDENT_H

#include "fs_pi.h"
#include "fs_transforms.h"
#include "fs_types.h"

typedef enum {
    FS_IDENT_START = 0, FS_IDENT_PROBE = 1, FS_IDENT_ALIGN = 2, FS_IDENT_LEVELS = 3,
    FS_IDENT_LDQ = 4, FS_IDENT_SPIN = 5, FS_IDENT_FLUX = 6, FS_IDENT_ACCEL = 7,
    FS_IDENT_COAST = 8, FS_IDENT_DONE = 9, FS_IDENT_FAILED = 10
} fs_ident_stepid;

/* the quantities, each with its own status and reason */
typedef enum {
    FS_IDQ_VERR = 0,     /* the inverter's voltage error u_e, i_e */
    FS_IDQ_RS = 1, FS_IDQ_LD = 2, FS_IDQ_LQ = 3, FS_IDQ_PSI_F = 4,
    FS_IDQ_J = 5, FS_IDQ_FRICTION = 6,
    FS_IDQ_N = 7
} fs_ident_quantity;

typedef enum { FS_IDS_PENDING = 0, FS_IDS_OK = 1, FS_IDS_FAILED = 2 } fs_ident_status;

typedef enum {
    FS_IDR_NONE = 0,
    FS_IDR_NO_CURRENT = 1,     /* the current did not answer the largest pulse: open phase or L beyond range */
    FS_IDR_OVERCURRENT = 2,    /* a sampled current beyond i_max */
    FS_IDR_LOW_SIGNAL = 3,     /* the signal is not well above its noise */
    FS_IDR_FIT = 4,            /* the fit's residual is too large (the model does not hold) */
    FS_IDR_MOVED = 5,          /* the rotor moved where it must stand still */
    FS_IDR_NOT_TURNING = 6,    /* no back-EMF where the rotor must turn */
    FS_IDR_LOST_SYNC = 7,      /* the rotor did not follow the I/f frame */
    FS_IDR_VOLTAGE = 8,        /* the voltage needed is beyond the link's linear range */
    FS_IDR_PREREQ = 9,         /* an earlier quantity it needs failed */
    FS_IDR_MISALIGNED = 10,    /* the magnet axis is not where the alignment put it */
    FS_IDR_TOO_FAST = 11,      /* the speed changed too fast to fit, even at the least current */
    FS_IDR_FRICTION = 12,      /* friction too large a share of the test torque for J */
    FS_IDR__COUNT = 13
} fs_ident_reason;

enum { FS_IDENT_NLEV = 7, FS_IDENT_NREC = 128, FS_IDENT_NBATCH = 8 };

typedef struct {
    float Ts;            /* control period, s */
    float delay;         /* computation delay, control periods: 0 or 1 */
    int pole_pairs;
    float i_max;         /* A peak: no test current above it */
    float w_spin;        /* el. rad/s: the running steps' speed (lowered to half the voltage limit) */
    float t_ramp;        /* s: the I/f ramp from 0 to w_spin (the inertia is not known before) */
    float u_dc_min;      /* V: below this link voltage the sequence does not start (0: 1 V) */
} fs_ident_config;

typedef struct {
    int status[FS_IDQ_N];        /* fs_ident_status */
    int reason[FS_IDQ_N];        /* fs_ident_reason */
    float u_e, i_e;              /* inverter error per leg at high current, V, and its knee, A */
    float R_s, L_d, L_q, psi_f;  /* ohm, H, Wb */
    float J, B, T_c;             /* kg m^2, N m s/rad, N m (mechanical) */
    float theta_d;               /* el. rad: the magnet axis the alignment found, checked by LDQ */
    /* what each decision saw (the ratio its check compared) */
    float r_fit_rs;              /* R_s: top-level residual over the signal */
    float snr_rs, snr_l, snr_psi;/* signal over the mean's noise */
    float eps_align;             /* rad, the misalignment the cross response shows */
    float w_flux;                /* el. rad/s where psi_f was read */
    float a_acc, a_coast;        /* el. rad/s^2 at the acceleration's mean speed */
    float I_lev[FS_IDENT_NLEV], U_lev[FS_IDENT_NLEV];   /* the d-axis level means, A, V */
    float I_bias[2], L_q_bias[2];    /* LDQ: the two d biases of the q injection, A, and L_q at each, H */
    float dL_q;                  /* L_q's change with i_d, H/A (the cross-saturation the injection estimators see) */
} fs_ident_result;

typedef struct {
    fs_ident_config cfg;
    fs_ident_result res;
    int step;            /* fs_ident_stepid */
    int k;               /* samples in the step */
    int sub;             /* sub-step counter */
    /* design values found on the way */
    float L0;            /* H, from PROBE */
    float u_p;           /* V, PROBE pulse */
    int n_p;             /* PROBE pulse length, samples */
    float i_peak;
    float sigma_i;       /* A, the current noise seen at standstill */
    float w_c;           /* rad/s current loop */
    fs_pi pi_d, pi_q;
    float u_max;         /* linear-range voltage of the last sample */
    /* accumulators */
    float s_u, s_i, s_uu, s_ib2, s_ii, s_ia;   /* about the shift below, for float precision */
    float u0, i0;        /* the shift: the window's first sample */
    float batch[FS_IDENT_NBATCH];   /* running sums of u at each batch's end */
    int n_acc;
    /* HF phasors: voltage and both currents, real and imaginary */
    float hf_u[2], hf_i[2][2];
    float U_h, w_h;
    /* frame: angle, speed, PLL */
    float theta, w, w_target, bw_pll, i_if, i_acc, w0;
    fs_ab u_prev[2];     /* the references of the last two samples (delay) */
    fs_dq u_dq;          /* the last frame voltage */
    float e_abs, w_abs;  /* sums over the psi_f window */
    int tries;
    /* the (t, w) record, decimated by doubling when full */
    float rec_t[FS_IDENT_NREC], rec_w[FS_IDENT_NREC];
    int rec_n, rec_dec, rec_k;
    float t_acc;         /* s the acceleration took */
    float w_acc;         /* el. rad/s, its mean speed */
} fs_ident;

fs_status fs_ident_init(fs_ident *id, const fs_ident_config *cfg);
void fs_ident_reset(fs_ident *id);
/* One control period: the sampled stationary currents and dc link in, the
 * stationary voltage reference for the next period out. */
fs_ab fs_ident_step(fs_ident *id, fs_ab i_ab, float u_dc);
/* A short text for a reason, and for a step (for reports). */
const char *fs_ident_reason_str(int reason);
const char *fs_ident_step_str(int step);
/* The fitted leg error g(i) = u_e i / sqrt(i^2 + i_e^2) (0 until LEVELS is done). */
float fs_ident_leg_error(const fs_ident *id, float i);

#endif /* FS_IDENT_H */
