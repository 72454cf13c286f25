/* Indirect matrix converter modulation (zou2021 sec. 3) and the rectifier
 * stage's modulation-depth controller (sec. 4.3, PART_2).
 *
 * Rectifier stage. From the input phase voltages alone (no input angle is
 * needed): x is the phase of largest magnitude, y and z the other two, whose
 * signs are both opposite to x's.
 *   CASE 1, eqs. (4)-(5): x stays on its rail for the whole period; the
 *     other rail is on z for d_z = -u_z/u_x of the period and on y for
 *     d_y = -u_y/u_x (d_y + d_z = 1: no zero vector, unity input power
 *     factor). Period mean, eq. (6): sum(u^2)/|u_x| = 3 V_im / (2 cos theta).
 *   CASE 2, eq. (7): the rails on the largest and the smallest phase for the
 *     whole period, eq. (8): v_pn = u_max - u_min.
 * The twelve sectors of Fig. 3a (pi/6 each) end where a phase peaks and
 * where the middle phase crosses zero (|u_max| = |u_min|, eq. (3)). With
 * the depth angle alpha, CASE 2 is used within alpha of the middle phase's
 * zero crossing (sector 1: [pi/6 - alpha, pi/6), eq. (11)), that is where
 * |u_mid| < V_im sin(alpha); CASE 1 elsewhere. Sector mean: eq. (12).
 * The interval on the largest line voltage (T_max) comes first; the one on
 * the middle line voltage (T_mid) second. The inverter stage repeats its
 * vector sequence inside each interval, starting and ending in a zero
 * vector, so the rectifier switches at zero dc-link current.
 *
 * Inverter stage. Space-vector modulation on the fictitious vectors of
 * eq. (13), whose length follows the period mean v_pn: fs_svpwm with
 * u_dc = v_pn is eq. (15) in the linear range and the minimum-phase-error
 * over-modulation of eq. (16) beyond it.
 *
 * Regions (sec. 3.3) by the demanded transfer ratio q = V_om / V_im (eq. (21)):
 * linear up to sqrt3/2 (the smallest hexagon's inscribed circle, 1.5 V_im /
 * sqrt3), over-modulation I up to eq. (20) with CASE 1 alone (0.954),
 * over-modulation II up to eq. (20) with CASE 2 alone (1.002).
 */
#ifndef FS_IMC_H
#define FS_IMC_H

#include "fs_types.h"

/* One rectifier interval: the input phases (0 a, 1 b, 2 c) on the positive
 * and the negative rail, and the share of the period. */
typedef struct {
    int p, n;
    float d;
} fs_imc_interval;

typedef struct {
    fs_imc_interval iv[2];   /* T_max interval, then T_mid (d = 0 in CASE 2) */
    float v_pn;              /* the period mean of the dc link, V (eqs. (6), (8)) */
    int sector;              /* 1..12, Fig. 3a */
    bool case2;              /* this period uses CASE 2 */
} fs_imc_rect;

typedef enum {
    FS_IMC_LINEAR = 0,       /* q <= sqrt3/2 */
    FS_IMC_OM1 = 1,          /* CASE 1, minimum-phase-error over-modulation */
    FS_IMC_OM2 = 2           /* CASE 1 and CASE 2 by alpha, over-modulation */
} fs_imc_region;

/* eq. (12): the sector mean of the dc link over V_im at depth angle alpha
 * (clamped to [0, pi/6]). */
float fs_imc_vpn(float alpha);
/* The largest VTR of a region: sqrt3/2 (linear), eqs. (20)-(21) with
 * eq. (12) at alpha (over-modulation). */
float fs_imc_vtr_max(int region, float alpha);
/* The region a demanded VTR q needs (sec. 3.3). */
int fs_imc_region_of(float q);
/* The depth angle that eqs. (12), (20) and (21) give for VTR q: 0 up to
 * over-modulation I's limit, pi/6 at and beyond over-modulation II's. */
float fs_imc_alpha_for_vtr(float q);
/* The rectifier's intervals for the input phase voltages u_in at depth
 * angle alpha. */
void fs_imc_rectifier(const float u_in[3], float alpha, fs_imc_rect *r);
/* The input phase voltages' amplitude, |u_alpha,beta|. */
float fs_imc_amplitude(const float u_in[3]);

/* PART_2, eq. (33): alpha = (I_ref - I_lim)(k_p + k_i/s), limited to
 * [0, pi/6] with a clamped integral, and gated by the flux-weakening
 * current's polarity (sec. 4.4): while the drive does not weaken the flux,
 * alpha = 0 and the integral is cleared. */
typedef struct {
    float Ts;          /* s */
    float k_p;         /* rad/A */
    float k_i;         /* rad/(A s) */
    float i_lim;       /* A, I_lim < I_max (sec. 4.3) */
} fs_imc_depth_config;

typedef struct {
    fs_imc_depth_config cfg;
    float integ;       /* rad */
    float alpha;       /* rad, the last output */
} fs_imc_depth;

/* Gains from the machine: raising alpha from 0 to pi/6 raises the
 * fundamental voltage by V_im (q(pi/6) - q(0)), which at the top
 * electrical speed w_e_max lowers the flux-weakening current by that over
 * w_e_max L: the plant gain G, A/rad. With k_i = bw / G and
 * k_p = 0.5 / G the loop gain is 0.5 + bw/s: it crosses over at 1.15 bw. */
fs_status fs_imc_depth_design(fs_imc_depth_config *cfg, float Ts, float i_lim, float V_im,
                              float w_e_max, float L, float bw);
fs_status fs_imc_depth_init(fs_imc_depth *dc, const fs_imc_depth_config *cfg);
void fs_imc_depth_reset(fs_imc_depth *dc);
/* i_ref = |i*| of eq. (32); weakening: the flux-weakening current is
 * negative. Returns alpha. */
float fs_imc_depth_step(fs_imc_depth *dc, float i_ref, bool weakening);

#endif /* FS_IMC_H */
