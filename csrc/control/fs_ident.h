/* Self-commissioning: the drive measures the machine it is about to run.
 *
 * A sequence of steps, each run from the sampled currents and dc link alone
 * (no position sensor), each checking that its own measurement can be
 * trusted and saying why not instead of returning a number. The standstill
 * steps keep the rotor where it rests: they find its axis without moving
 * it and put their currents on it (no torque on an aligned rotor), with
 * the signs alternating (a misalignment's magnet torque alternating too):
 *
 *   PROBE   voltage pulses on alpha, doubled until the current answers: a
 *           coarse inductance for the current loop's design (the pulse
 *           amplitude from i_max and Ts: the current may reach i_probe in
 *           n_p samples, u_p = L i_probe / (n_p Ts)).
 *   AXIS    an alternating HF voltage (a tenth of the sampling rate) on
 *           alpha, then on beta, at zero current (no torque but the
 *           carrier's, of zero mean): the inductance tensor, whose low
 *           axis is the rotor's d axis (modulo pi), and L_d, L_q with the
 *           saliency. Without saliency (below 3 %) the axis cannot be seen
 *           standing: ALIGN then turns the rotor to it.
 *   ALIGN   (no saliency, or the polarity not seen and the rotor may turn)
 *           dc current on alpha, beta held at zero voltage (a short circuit
 *           there damps the rotor's swing by its own back-EMF): the
 *           magnet's north settles on alpha (the rotor turns up to half a
 *           turn); the current below half of psi_f / (L_q - L_d).
 *   POLARITY the map's d sweep (fs_mapid.h) on the axis, R_s and the
 *           inverter's error not known yet: its saturation asymmetry says
 *           which end of the axis is the magnet's north, and the q flux it
 *           raises how far the axis is off the rotor's (turned onto it).
 *   LEVELS  dc current steps on the d axis at FS_IDENT_NLEV levels: on the
 *           north pole (polarity known) +I only, the top level below half
 *           of psi_f / (L_q - L_d) (the nameplate's psi_f): there the
 *           magnet holds the rotor against the reluctance torque, which
 *           turns a rotor's q axis towards a larger current (the Prius-like
 *           machine's rest at 150 A is 74 el.deg off the current); the
 *           polarity unknown (standstill_only or locked), each level at +I
 *           then -I (a misalignment's magnet torque alternating with them;
 *           a -I current pushes the magnet away, so the rotor must be held:
 *           friction, or locked).
 *           The inverter's voltage error against current (dead time,
 *           device drops), from half the difference of the two signs'
 *           voltages where both are there (offsets cancel), fitted per
 *           leg as g(i) = u_e i / sqrt(i^2 + i_e^2), and R_s from the
 *           slope of the top three levels, where the error is flat. The
 *           top level is i_test (0.6 i_max unless given).
 *   LDQ     the HF on d at zero current (the axis refined by the cross
 *           response: the rotor's turn since AXIS), then on q at two d
 *           biases that keep its legs' currents off zero (the dead time's
 *           error then constant): I_b and 2 I_b on the north pole within
 *           the levels' bound, else +I_b and -I_b; L from the response's
 *           reactance (exact for a sampled R-L branch with the computation
 *           delay), L_q at zero current by the line through the two, its
 *           change with i_d.
 *   CHECK   the HF on d at zero current again (the cross response): how
 *           far the rotor turned, before MAP (the frame turned onto it) and
 *           after it.
 *   MAP     the flux map at standstill (fs_mapid.h): a d sweep, its drop
 *           compensated now, then q sweeps at the d levels, each of zero
 *           mean torque.
 *   SPIN    I/f: the current on the frame's d axis, the frame accelerated
 *           to w_spin (or to the speed where |u| reaches half the linear
 *           limit) in t_ramp. Where the polarity is not known (no
 *           saturation asymmetry, or no map), the current first pulls the
 *           rotor from 90 deg off and turns to the axis (as ALIGN): a
 *           rotor whose south pole the axis was turns half a turn.
 *   FLUX    zero current, the frame locked on the back-EMF by a PLL: at
 *           zero current the voltage is the EMF (R_s and L drop out),
 *           psi_f = |e| / |w|.
 *   DCURVE  (the map) the map's d levels on that frame at i_q = 0, each
 *           held: psi_d(i_d, 0) = (u_q - R_s i_q) / w from the steady
 *           voltage equations (no torque: i_q = 0 and psi_q(i_d, 0) = 0,
 *           so the PLL stays on the d axis), where the voltage allows.
 *   ACCEL   i_q = i_acc in that frame: the acceleration of a known torque,
 *           the measured current's (in the rotor's frame: the frame's lag
 *           behind the back-EMF turned out) weighed as the speed's fit
 *           weighs the acceleration (the same fit of its impulse).
 *   COAST   zero current again: the deceleration by friction alone, over
 *           two halves (B and T_coulomb); J = T / (a_acc - a_coast).
 * and DONE (zero current held on the tracking frame) or FAILED. With
 * standstill_only or locked set the sequence ends after CHECK (psi_f, J
 * and friction skipped); skip_map leaves MAP and DCURVE out.
 *
 * Where the design values come from: the probe's pulse from i_max and Ts
 * (doubled from 1 % of the link until the current answers); the current
 * loops' bandwidth from Ts (0.1/Ts), their gains from the probe's L, then
 * AXIS's, later the measured R_s, L_d, L_q; the levels' settling from that
 * bandwidth and their windows from the noise (batch means); the carriers
 * from i_max and the impedance |R_s + j w_h L| at w_h = 2 pi / (10 Ts);
 * the map's sweeps from L_d, L_q, R_s and (their motion) the nameplate's
 * psi_f and J; the PLL from the current loop and the spin's speed; the
 * acceleration's current from a first try, cut by four while the speed
 * changes faster than the PLL can follow (the mechanical time constant
 * found on the way); the coast from the acceleration's duration. Each
 * constant's reason is beside it in fs_ident.c.
 *
 * Three phases, float32, no heap, no globals. The instance holds the
 * result; fs_ident_step returns the stationary voltage reference the drive
 * modulates (within the linear range, so that it is realised).
 */
#ifndef FS_IDENT_H
#define FS_IDENT_H

#include "fs_mapid.h"
#include "fs_pi.h"
#include "fs_transforms.h"
#include "fs_types.h"

typedef enum {
    FS_IDENT_START = 0, FS_IDENT_PROBE = 1, FS_IDENT_AXIS = 2, FS_IDENT_ALIGN = 3, FS_IDENT_POLARITY = 4,
    FS_IDENT_LEVELS = 5, FS_IDENT_LDQ = 6, FS_IDENT_MAP = 7, FS_IDENT_CHECK = 8, FS_IDENT_SPIN = 9,
    FS_IDENT_FLUX = 10, FS_IDENT_DCURVE = 11, FS_IDENT_ACCEL = 12, FS_IDENT_COAST = 13, FS_IDENT_DONE = 14,
    FS_IDENT_FAILED = 15, FS_IDENT_NSTEPS = 16
} fs_ident_stepid;

/* the quantities, each with its own status and reason */
typedef enum {
    FS_IDQ_VERR = 0,     /* the inverter's voltage error u_e, i_e */
    FS_IDQ_RS = 1, FS_IDQ_LD = 2, FS_IDQ_LQ = 3,
    FS_IDQ_MAP = 4,      /* the flux map psi_d(i_d, i_q), psi_q(i_d, i_q) */
    FS_IDQ_PSI_F = 5, FS_IDQ_J = 6, FS_IDQ_FRICTION = 7,
    FS_IDQ_N = 8
} fs_ident_quantity;

/* SKIPPED: not measured by the configuration's choice (its reason says which) */
typedef enum { FS_IDS_PENDING = 0, FS_IDS_OK = 1, FS_IDS_FAILED = 2, FS_IDS_SKIPPED = 3 } fs_ident_status;

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
    FS_IDR_STANDSTILL = 13,    /* skipped: the rotor may not turn (standstill_only) */
    FS_IDR_LOCKED = 14,        /* skipped: the rotor is locked */
    FS_IDR_NOT_ASKED = 15,     /* skipped: not asked for (skip_map) */
    FS_IDR_INCOMPLETE = 16,    /* the sweeps did not read the grid (a current that did not follow) */
    FS_IDR_UNSTABLE = 17,      /* the d sweep to the grid's ends would turn the free rotor away (lock it) */
    FS_IDR_NO_POLARITY = 18,   /* the polarity not seen standing and the rotor may not turn: the levels need it locked */
    FS_IDR_NO_AXIS = 19,       /* no saliency: the d axis not seen standing, and the rotor may not be turned to it */
    FS_IDR__COUNT = 20
} fs_ident_reason;

enum { FS_IDENT_NLEV = 7, FS_IDENT_NREC = 128, FS_IDENT_NBATCH = 8, FS_IDENT_NVISIT = 24 };

typedef struct {
    float Ts;            /* control period, s */
    float T_pwm;         /* carrier period, s (Ts or 2 Ts; 0: Ts): the current's ripple the inverter's error sees */
    float delay;         /* computation delay, control periods: 0 or 1 */
    int pole_pairs;
    float i_max;         /* A peak: no test current above it */
    float w_spin;        /* el. rad/s: the running steps' speed (lowered to half the voltage limit) */
    float t_ramp;        /* s: the I/f ramp from 0 to w_spin (the inertia is not known before) */
    float u_dc_min;      /* V: below this link voltage the sequence does not start (0: 1 V) */
    int standstill_only; /* 1: the rotor may not turn: the standstill steps only */
    int locked;          /* 1: the rotor is held (a brake, a locked shaft): standstill steps only, no motion bound */
    int skip_map;        /* 1: no flux map (MAP, DCURVE) */
    float i_test;        /* A: the levels' top current (0: 0.6 i_max) */
    float t_level;       /* s: the top levels' window per sign (0: 0.1 s) */
    float psi_f_hint, J_hint;   /* Wb, kg m^2, the nameplate's: size the map's q sweeps against the rotor's motion (0: unknown) */
    float motion_max;    /* el. rad: the map's q sweeps' motion bound (0: 1 el.deg) */
} fs_ident_config;

typedef struct {
    int status[FS_IDQ_N];        /* fs_ident_status */
    int reason[FS_IDQ_N];        /* fs_ident_reason */
    float u_e, i_e;              /* inverter error per leg at high current, V, and its knee, A */
    float R_s, L_d, L_q, psi_f;  /* ohm, H, Wb */
    float J, B, T_c;             /* kg m^2, N m s/rad, N m (mechanical) */
    float theta_axis;            /* el. rad, stationary: the axis AXIS found (ALIGN: 0), then the frame the steps used (+pi where MAP found the south pole) */
    float theta_hf;              /* el. rad, stationary: the axis AXIS's carriers found (modulo pi) */
    float saliency;              /* (L_q - L_d) / (L_q + L_d) at zero current, from AXIS */
    float L_d_axis, L_q_axis;    /* H: AXIS's inductances (a tenth of the sampling rate, Euler's model) */
    float motion_ldq, motion_premap, motion_check;  /* el. rad: the rotor's turn seen by LDQ's d carrier (since AXIS: POLARITY,
                                                      LEVELS), by CHECK before MAP (LDQ's biases) and after it (MAP) */
    float i_moved;               /* A: the test current when a step found the rotor moving (its sign: the d axis') */
    float pol_asym;              /* POLARITY: the d sweep's asymmetry (incremental L_d at -3/4 i_max against +3/4 i_max, or at +-i_max/2 where the sweep did not step there enough; relative) */
    int pol_decided, pol_flipped;/* it decided the polarity; the axis was the south pole (turned by pi) */
    float pol_amp;               /* A: its sweep's amplitude (cut where the free rotor would turn away; 0: not swept) */
    float i_level_top;           /* A: the levels' top current as used (i_test, or the reluctance bound) */
    float noise_i;               /* A rms: the current sensors' noise at zero voltage (START) */
    /* what each decision saw (the ratio its check compared) */
    float r_fit_rs;              /* R_s: top-level residual over the signal */
    float snr_rs, snr_l, snr_psi;/* signal over the mean's noise */
    float eps_align;             /* rad, the misalignment the cross response shows */
    float w_flux;                /* el. rad/s where psi_f was read */
    float a_acc, a_coast;        /* el. rad/s^2 at the acceleration's mean speed */
    float I_lev[FS_IDENT_NLEV], U_lev[FS_IDENT_NLEV];   /* the d-axis level means, A, V */
    float I_bias[4], L_q_bias[4];    /* LDQ: the d biases of the q injection (two; four on a locked rotor), A, and L_q at
                                        each, H */
    float dL_q;                  /* L_q's change with i_d, H/A (the cross-saturation the injection estimators see) */
    float ld_carrier;            /* LDQ: the d carrier's current amplitude L_d was read at, A (I_HF_D i_max, halved while its
                                    response's second harmonic showed the axis lopsided over the swing) */
    float ld_h2;                 /* LDQ: that response's second harmonic over its fundamental (the current's) */
    float I_levn[FS_IDENT_NLEV], U_levn[FS_IDENT_NLEV];  /* the levels at -I (alternating), A, V */
    /* DCURVE: psi_d(i_d, 0) at speed at the map's d levels k i_max / 4 (k = -4..4, index k + 4), the d
     * current and the speed it was read at (w 0: not measured) */
    float psi_d_w[FS_MAPID_ND], i_d_w[FS_MAPID_ND], w_d_w[FS_MAPID_ND];
    int n_step[FS_IDENT_NSTEPS]; /* control periods spent in each step */
    /* the steps in the order they ran (CHECK runs twice) and the period each began at (the first
     * FS_IDENT_NVISIT of them) */
    int n_visit, n_total;
    int visit_step[FS_IDENT_NVISIT], visit_at[FS_IDENT_NVISIT];
} fs_ident_result;

typedef struct {
    fs_ident_config cfg;
    fs_ident_result res;
    fs_mapid map;        /* MAP's sweeps and their result */
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
    float theta_s;       /* el. rad: the standstill steps' d axis (stationary) */
    int aligned;         /* the axis came from ALIGN (no saliency): positive levels and biases only */
    int pol_known;       /* the frame's d axis is the magnet's north (ALIGN, or POLARITY's or MAP's asymmetry decided) */
    float i_ref0;        /* A: DCURVE's last level, the next one's ramp starts there */
    float ax_i[2][2][2], ax_u[2][2][2];   /* AXIS: the current and voltage phasors [injection][axis][re, im] */
    float i_peak_b;                      /* PROBE: beta's peak current */
    float u_pb;                          /* PROBE: beta's pulse voltage */
    float L0_min;                        /* PROBE: the smaller of alpha's and beta's L (AXIS's hold loop gain) */
    float q_set;                         /* LEVELS: the q voltage's sum over the settling's second half */
    float ax_hold[2];                    /* AXIS: the hold loop's dc voltage, per axis */
    float ax_isum[2];                    /* AXIS: the carrier period's current sum, per axis */
    /* accumulators */
    float s_u, s_i, s_uu, s_ib2, s_ii, s_ia;   /* about the shift below, for float precision */
    float u0, i0;        /* the shift: the window's first sample */
    float batch[FS_IDENT_NBATCH];   /* running sums of u at each batch's end */
    int n_acc;
    /* HF phasors: voltage and both currents, real and imaginary */
    float hf_u[2], hf_i[2][2];
    float hf_i2[2];      /* the carrier axis' current at twice the carrier's frequency (LDQ's d carrier) */
    float hf_scale;      /* LDQ: the d carrier's amplitude, of I_HF_D i_max (0: not begun) */
    float ld_L_prev;     /* LDQ: the d carrier's last pass' L, H (0: none) */
    float U_h, w_h;
    /* frame: angle, speed, PLL */
    float theta, w, w_target, bw_pll, i_if, i_acc, w0;
    fs_ab u_prev[2];     /* the references of the last two samples (delay) */
    fs_dq u_dq;          /* the last frame voltage */
    float e_abs, w_abs;  /* sums over the psi_f window */
    int tries;
    /* the (t, w, g) record, decimated by doubling when full: g the torque's
     * impulse, N m s, since the record began (ACCEL's, from the measured
     * current in the rotor's frame; 0 in COAST) */
    float rec_t[FS_IDENT_NREC], rec_w[FS_IDENT_NREC], rec_g[FS_IDENT_NREC];
    int rec_n, rec_dec, rec_k;
    float g_acc;         /* N m s: the torque's impulse since ACCEL began */
    float T_acc;         /* N m: the torque as the acceleration's fit weighs it (the slope of g over its window) */
    float t_acc;         /* s the acceleration took */
    float w_acc;         /* el. rad/s, its mean speed */
    float w_level;       /* el. rad/s: the speed a DCURVE level began at */
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
