/* Flux-map identification at standstill: psi_d(i_d, i_q) and psi_q(i_d, i_q)
 * over the current limit's disc, from current sweeps whose flux is the
 * integral of the voltage that acted, read where the current crosses the
 * grid's values (fs_ident.h runs it in its MAP step, on the axis it found).
 *
 * The sweeps are bang-bang: a constant voltage +-U on the swept axis,
 * reversed when the current passes the sweep's amplitude, while a PI
 * holds the other axis' current. The flux is integrated over each period
 * from the voltage that acted in it (the reference of d periods before)
 * less R_s i and the inverter's fitted error, at the mean of the period's
 * two current samples, and less the speed voltage of a free rotor's swing
 * (w psi_q on d, -w psi_d on q; w from the torque's impulse since the
 * rotor was last at rest, over the psi_f and J given: the swing's angle
 * theta would read psi_d theta into the q flux and -psi_q theta into the
 * d flux, 1.7 % of psi_f an el.deg; a J given 30 % off leaves 30 % of it,
 * and friction is left out); at a crossing of a grid value it is interpolated
 * between the two samples around it. Each leg records each grid value
 * once, in its own direction (a leg is read until the current has turned,
 * the computation delay after the voltage).
 *
 * Why crossings: what the inverter's error model and R_s leave over is a
 * voltage e(i) of the current; on a leg at slope r it adds (1/r) times its
 * integral over the currents passed, and the mean over a value's up and
 * down crossings keeps a constant that depends on the pattern, not on the
 * value. For the q sweeps' pattern
 *     0 -> +a I -> -I -> +I -> -a I -> 0, a = (sqrt 5 - 1)/2
 * (each value read 4 times a side within a I, twice beyond, 0 five times)
 * that constant cancels in
 *     psi_q(i_d, x) = (mean at +x - mean at -x) / 2           for e_q odd in i_q,
 *     psi_d(i_d, x) - psi_d(i_d, 0) = (mean at +x + mean at -x) / 2 - mean at 0
 *                                                             for e_d even in i_q,
 * (psi_q is odd in i_q and psi_d even), and the torque's impulse and the
 * rotor's displacement over it are zero: the rotor is left where it was,
 * at rest, having swung by about 0.46 A t_I^2 (A its angular acceleration
 * at I, t_I the time 0 -> I takes). What the model's misfit leaves of the
 * impulse (the ramps' slopes a few per cent apart) is measured, the q
 * current's integral, and cancelled by a triangular trim pulse after the
 * sweep: a rotor left turning would drift on through the next sweeps. The d sweep's pattern
 *     0 -> +I -> -I -> +I -> 0
 * leaves a quarter of the error's integral over 0..I on the positive side.
 * The inverter's error model needs to be right only to keep these small.
 *
 * The sweeps:
 *   D       the d axis at i_q = 0, to +-i_max, read at k i_max / 4
 *           (k = -4..4): psi_d(i_d, 0) - psi_d(0, 0).
 *           No torque on an aligned rotor (i_q = 0 on its axis), the d
 *           current's 2 % of i_max a sample (the overshoot after a reversal
 *           within 5 % of i_max). Its asymmetry decides the polarity: a
 *           d current that adds to the magnet's flux saturates the iron, so
 *           the incremental L_d at +3/4 i_max is below that at -3/4 i_max
 *           when the frame's d axis is the magnet's north (at +-i_max/2
 *           where the sweep did not step there enough; nearer zero the
 *           ribs the magnet saturates can turn it round: fs_mapid.c). L comes from the
 *           current's steps a sample on the legs up and down at the same
 *           current: 2 U Ts / (step up - step down), free of what the drop
 *           (R_s i and the inverter's error, the same on both legs) does
 *           to either (the polarity is decided before they are known).
 *           The q flux it raises (the q current held at zero) shows how
 *           far the rotor's axis is off the frame's: psi_q = (psi_d(i_d) -
 *           psi_f - L_q i_d) x the offset, read at +-i_max/2. Where the first leg's
 *           rise shows a drop above a quarter of U (a
 *           low link's R_s i, a high link's dead time, stall the rise), U
 *           is raised to four times it and the sweep starts again. With
 *           d_only (the polarity, R_s and the inverter's error unknown) it
 *           goes to +-0.8 i_max. Found on the
 *           south,
 *           the unit turns its frame by pi (negates what it reads and
 *           writes) and mirrors what it read.
 *   Q(k)    at each d level I_d = k i_max / 4, k = 0, 1, -1, 2, -2, 3, -3
 *           (alternating, so that a misalignment's magnet torque
 *           alternates too), i_q swept to +-I_q and read at j i_max / 8
 *           (j = 1..8): the torque's sign follows i_q's, so its mean over
 *           the pattern is zero (psi_d is even and psi_q odd in i_q). I_q
 *           is the disc's sqrt(i_max^2 - I_d^2) less the overshoot, or less
 *           where the rotor would turn too far: a sweep of amplitude I whose
 *           rise 0 -> I takes t_q swings a free rotor by about
 *           0.46 a t_q^2 el. rad (a = p^2 1.5 (psi_f + (L_q - L_d) |I_d|) I / J,
 *           the angular acceleration at the peak), so t_q is sized from
 *           motion_max (from psi_f and J, the nameplate's or those
 *           identified), at least N_Q_MIN samples (the crossings' resolution),
 *           and I is lowered until the voltage that t_q needs is there.
 *           A locked rotor (or psi_f or J unknown: 0) has no such bound.
 * A d level other than 0 turns a misaligned free rotor further off the axis
 * where the magnet's pull is below the reluctance torque's push (every
 * i_d < 0, and i_d > psi_f / (L_q - L_d)): the error grows as cosh(t / tau),
 * tau = sqrt(J / (p 1.5 p |psi_f i_d - (L_q - L_d) i_d^2|)). A level whose
 * time would grow it more than threefold is not swept (its row comes from
 * its neighbours), unless the rotor is locked (psi_f or J 0). Between
 * levels the d current returns to zero; a q voltage there beyond what the
 * inverter's error explains is a turning rotor's back-EMF: the sweeps stop.
 *
 * Float32, no heap. The d-q frame is the caller's (standstill: fixed).
 */
#ifndef FS_MAPID_H
#define FS_MAPID_H

#include "fs_pi.h"
#include "fs_transforms.h"
#include "fs_types.h"

enum { FS_MAPID_ND = 9, FS_MAPID_NQ = 8, FS_MAPID_NT = (2 * FS_MAPID_NQ) + 1 };

typedef enum { FS_MAPID_DSWEEP = 0, FS_MAPID_IN = 1, FS_MAPID_QSWEEP = 2, FS_MAPID_TRIM = 3, FS_MAPID_OUT = 4, FS_MAPID_DONE = 5 } fs_mapid_stage;

/* why a level's q sweep stopped short of the disc, or was not run (UNSTABLE: the d level itself would turn
 * the free rotor away from the axis within the level's time, MOVING: the rotor was seen turning, the sweeps stopped) */
typedef enum { FS_MAPID_LIM_DISC = 0, FS_MAPID_LIM_MOTION = 1, FS_MAPID_LIM_VOLTAGE = 2, FS_MAPID_LIM_UNSTABLE = 3,
               FS_MAPID_LIM_MOVING = 4 } fs_mapid_limit;

typedef struct {
    float Ts;            /* s */
    float delay;         /* control periods: 0 or 1 */
    float i_max;         /* A: the disc's radius */
    float L_d, L_q, R_s; /* H, H, ohm: small-signal, for the sweeps' voltages and the loops */
    float u_e;           /* V: the inverter's error per leg at high current (the sweeps' voltage stays well above it) */
    int pole_pairs;
    float psi_f, J;      /* Wb, kg m^2: size the q sweeps against the rotor's motion (0: no bound) */
    float motion_max;    /* el. rad: the q sweeps' motion bound (0: no bound) */
    float w_c;           /* rad/s: the holding loops' bandwidth */
    int d_only;          /* 1: the d sweep alone (the polarity before R_s and the inverter's error are known) */
    int pol_known;       /* 1: the frame's d axis is the magnet's north already (ALIGN, or the polarity's sweep): the d
                            sweep reports its asymmetry but never turns the frame */
} fs_mapid_config;

typedef struct {
    /* the d axis, i_q = 0: psi_d(k i_max/4, 0) - psi_d(0, 0), index k + 4 */
    float dpsi_d[FS_MAPID_ND];
    int n_d[FS_MAPID_ND];                    /* crossings read (0: not reached) */
    float L_pos, L_neg;                      /* H: incremental L_d at +-pol_level i_max (the current's steps there) */
    float pol_level;                         /* of i_max: where the asymmetry was read: 3/4 where the sweep stepped
                                                there enough, else 1/2 */
    float asym;                              /* (L_neg - L_pos) / max: > 0 the frame was on the north */
    int flipped;                             /* it was on the south: turned by pi */
    int decided;                             /* the asymmetry decided the polarity (either way) */
    float d_amp;                             /* A: the d sweep's amplitude (0: not swept, the free rotor would turn away) */
    int d_limit;                             /* fs_mapid_limit: DISC, or UNSTABLE where the free rotor's motion cut it */
    float d_growth;                          /* the exponent its design allows a misalignment to grow by (cosh of it: the factor) */
    float axis_offset;                       /* el. rad: the rotor's d axis against the frame's, from the q flux the d sweep
                                                raised: psi_q = (psi_d(i_d) - psi_f - L_q i_d) x the offset */
    /* the q sweeps, index [k + 4][j - 1] */
    float psi_q[FS_MAPID_ND][FS_MAPID_NQ];   /* Wb */
    float dpsi_dq[FS_MAPID_ND][FS_MAPID_NQ]; /* Wb: psi_d(I_d, j i_max/8) - psi_d(I_d, 0) */
    float i_d_at[FS_MAPID_ND][FS_MAPID_NQ];  /* A: the d current at those crossings */
    int n_q[FS_MAPID_ND][FS_MAPID_NQ];
    float i_q_amp[FS_MAPID_ND];              /* A: each level's sweep amplitude */
    int limit[FS_MAPID_ND];                  /* fs_mapid_limit */
    float motion[FS_MAPID_ND];               /* el. rad: the swing its sizing allows (0.46 a t_q^2; 0 unbounded) */
    float psi_q_end[FS_MAPID_ND];            /* Wb: the q flux back at zero current after the level (-psi_f x its net turn) */
    float impulse_left[FS_MAPID_ND];         /* A s: the torque's impulse over 1.5 p psi_f left after the level's trim (fs_mapid.torque_imp) */
} fs_mapid_result;

typedef struct {
    fs_mapid_config cfg;
    fs_mapid_result res;
    int stage, level, k, leg, rleg;   /* rleg: the leg the crossings read (the current turns a delay after the voltage) */
    fs_pi pi_d, pi_q;    /* the held axes' loops */
    float I_d;           /* A: this level's d current */
    float I_amp;         /* A: the swept axis' reversal current */
    float U;             /* V: the sweep's voltage (the drop fed forward on top) */
    int n_rise;          /* samples a q sweep's current takes from 0 to its amplitude, as planned */
    float impulse;       /* A s: the q current's integral over the sweep (the torque's impulse over 1.5 p psi_d) */
    float torque_imp;    /* A s: the torque's impulse over 1.5 p psi_f since the last trim (the q current's integral weighted by
                            psi_f + (L_d - L_q) i_d over psi_f): each q sweep's trim cancels what the d sweep, the levels and it left */
    int n_trim;          /* samples of each half of the trim pulse that cancels it; the d sweep: samples to wait before a restart */
    int restarts;        /* the d sweep's restarts at a higher voltage */
    float psi_d, psi_q;  /* Wb: integrated since the sweep's start */
    float x_prev, y_prev;/* the last sample's swept and held currents */
    float dx_last;       /* A: the swept current's last step (leg_next: the steps' growth) */
    float e_prev_d, e_prev_q;
    fs_dq u_out[2];      /* the last two outputs (the delay) */
    unsigned seen;       /* the grid values this leg has read */
    float s_x[FS_MAPID_NT], s_y[FS_MAPID_NT], s_i[FS_MAPID_NT];   /* sums per grid value: the swept axis' flux, the held axis' flux and current */
    float s_up[FS_MAPID_NT], s_dn[FS_MAPID_NT];   /* sums per grid value of the current's steps a sample up and down within half a grid step of it */
    int c_up[FS_MAPID_NT], c_dn[FS_MAPID_NT];
    int s_n[FS_MAPID_NT];
} fs_mapid;

fs_status fs_mapid_init(fs_mapid *m, const fs_mapid_config *cfg);
void fs_mapid_reset(fs_mapid *m);
/* One period at standstill: the sampled frame currents, the inverter's
 * error voltage at them (frame) and the linear-range voltage; the frame
 * voltage for the next period. */
fs_dq fs_mapid_step(fs_mapid *m, fs_dq i, fs_dq e_inv, float u_max);

#endif /* FS_MAPID_H */
