/* Synchronous-frame current controller with decoupling.
 *
 * Per axis a 2DOF PI designed from the machine model and the closed-loop
 * bandwidth alpha: with the cross-coupling and back-EMF fed forward,
 * L di/dt = u' - R i, and fs_pi_design places the sampled loop's poles at
 * exp(-alpha Ts) (k_t ~ alpha L, k_p ~ 2 alpha L - R, k_i ~ alpha^2 L), so
 * i/i_ref is first order with bandwidth alpha.
 *
 * With a computation delay the voltage computed now acts only from the next
 * sample on; the controller then works on the current predicted for that
 * instant from the model and the voltage acting meanwhile (a one-step
 * predictor), so that the loop keeps its designed bandwidth and the delay
 * appears as a pure delay of the response.
 *
 * With a flux map (fs_current_ctrl_set_flux, each step) the cross-coupling
 * and the back-EMF are the map's fluxes, u_d' = -w psi_q(i), u_q' = w
 * psi_d(i), linearised at the caller's point (the drive: the last measured
 * current) with the map's incremental inductances, in the predictor and
 * the feed-forward; and the gains and
 * the predictor's plant follow the incremental inductances (the gains
 * scale with L, k_t ~ alpha L: the loop keeps its bandwidth where the
 * machine saturates; while not injecting and not on the isotropic loops
 * the drive gives them continuous across the map's grid lines,
 * fs_fluxmap_slopes and fs_drive.c: the bilinear cells' own slopes step
 * there, and the 2DOF output with them by (k_t - k_p) i ds, 100 V on SyR-e's
 * THOR at i_q = 11 A, each time the measured current crossed the line).
 * Without the map's fluxes a saturated machine's
 * feed-forward misses by w (psi_q - L_q i_q): on the 2004 Prius MG2 at
 * 1540 rpm deep in flux weakening 70 V, which the integrals could not
 * make up at the voltage limit (i_d stuck at -35 A for -200 A asked).
 * Given the map's flux at the reference (fs_current_ctrl_set_flux_ref,
 * where the caller measures the angle) the PIs work on the fluxes
 * themselves, whose plant d psi / dt = u - R i - j w psi holds whatever the
 * saturation: a step across it no longer overshoots the current limit.
 */
#ifndef FS_CURRENT_CTRL_H
#define FS_CURRENT_CTRL_H

#include "fs_fluxmap.h"
#include "fs_pi.h"
#include "fs_transforms.h"

typedef struct {
    float Ts;          /* control period, s */
    float R_s;         /* ohm */
    float L_d, L_q;    /* H */
    float psi_f;       /* Wb */
    float bandwidth;   /* closed-loop bandwidth alpha, rad/s */
    int predict;       /* 1: compensate one period of computation delay */
    /* explicit gains of ordinary PIs (k_t = k_p) per axis, V/A and V/(A s),
     * e.g. a paper's; all 0: the 2DOF design from the bandwidth */
    float k_p_d, k_i_d, k_p_q, k_i_q;
} fs_current_ctrl_config;

typedef struct {
    fs_current_ctrl_config cfg;
    fs_pi pi_d, pi_q;
    fs_dq ref, meas, u, u_ff;  /* kept from step for update */
    fs_dq u_prev;              /* realised voltage acting until the next sample */
    float a_d, b_d, a_q, b_q;  /* sampled plant per axis, for the predictor */
    /* a flux map's linearisation for the step (fs_current_ctrl_set_flux):
     * psi(i) = psi0 + (L_dd, L_qq)(i - i0); s = L / the configured L (the
     * gains' scale; ref and meas hold s i then) */
    bool map;
    fs_dq i0, psi0;
    float L_dd, L_qq, s_d, s_q;
    float L_dq;                /* the cross terms, for the flux at the measured current (set_flux_ref) */
    float L_qd;
    /* the map's flux at the coming step's reference (fs_current_ctrl_set_flux_ref), given for that
     * step (psi_ref_on); whether the last step was on the fluxes */
    fs_dq psi_ref;
    bool psi_ref_on;
    bool on_flux;
    /* fs_current_ctrl_set_isotropic: its caller's last ask, and whether both
     * axes are on the smaller inductance (asked, and the gains designed
     * here); the inductances the PIs and the predictor's plant are designed for */
    bool iso_asked;
    bool iso;
    float L_d_pi;
    float L_q_pi;
} fs_current_ctrl;

/* The internal-model design (Harnefors & Nee 1998, zou2021 ref. [22] and
 * sec. 4.2) as explicit gains in cfg, from its Ts, R_s, L_d, L_q and
 * bandwidth: an ordinary PI per axis with k_p = alpha L, k_i = alpha R_s,
 * whose zero sits on the machine's pole R_s/L, so that u = alpha L (s +
 * R_s/L)/s e gives i/i_ref = alpha/(s + alpha); in its sampled form, the
 * zero on the sampled plant's pole a (k_i Ts = k_p (1 - a)) and the loop's
 * pole at exp(-alpha Ts), as the pole placement's. Its integral rejects a
 * disturbance only at R_s/L. fs_current_ctrl_init checks the result. */
void fs_current_ctrl_internal_model(fs_current_ctrl_config *cfg);
fs_status fs_current_ctrl_init(fs_current_ctrl *cc, const fs_current_ctrl_config *cfg);
void fs_current_ctrl_reset(fs_current_ctrl *cc);
/* Voltage reference (not yet limited) for current reference and measurement
 * at electrical speed w_e. */
fs_dq fs_current_ctrl_step(fs_current_ctrl *cc, fs_dq i_ref, fs_dq i, float w_e);
/* While the frame's axes are not known (an I/f start, the polarity test's
 * lock, a recovery: fs_drive.c), both axes as if their inductance were the smaller one
 * (the map's smaller incremental inductance with a map): with the frame 90
 * el.deg off, the q axis's gains, alpha L_q, act on the machine's L_d, a
 * loop gain L_q / L_d above its design; on a PM-SyRM (L_q / L_d 5..8) the
 * sampled loop is then unstable, its voltage at the limit from the first
 * millisecond while the injection looks for the angle (the Baldor and
 * SyR-e's THOR from 90 and 270 el.deg: an overspeed stop, no polarity).
 * With the smaller L on both the loop keeps alpha on that axis and at
 * least alpha L_min / L_max on the other, in any frame. Off again: the
 * design's own axes. Explicit gains (a paper's) are kept as given. The
 * integrals are kept (voltages); cold: at the phase's changes only. */
void fs_current_ctrl_set_isotropic(fs_current_ctrl *cc, bool on);
/* A flux map at the current i0 (the last reference), for the next step (header). */
void fs_current_ctrl_set_flux(fs_current_ctrl *cc, fs_dq i0, const fs_fluxmap_point *p);
/* The map's flux at the reference of the coming step (Wb), after
 * fs_current_ctrl_set_flux; for that step only. The PIs then work on the
 * fluxes, psi(i_ref) against psi(i) one period ahead on the voltage
 * equation (over the inductances they are designed for), not on the
 * currents times the incremental inductance at the measured current.
 * Where the machine saturates between the two (a step of the reference
 * from zero to the current limit) the latter asks for the flux the
 * unsaturated inductance gives, far more than the reference's: SyR-e's
 * THOR stepped by its speed loop to 44 A reached 53.7 A (1.22 x), the
 * measured Baldor PM-SyRM 21.0 A against 18.7 A; on the fluxes 43.6 and
 * 18.7. Not with the isotropic loops (fs_current_ctrl_set_isotropic),
 * whose frame is not the map's. A step without it is on the currents; the
 * change either way is bumpless. */
void fs_current_ctrl_set_flux_ref(fs_current_ctrl *cc, fs_dq psi_ref);
/* Anti-windup: the voltage actually realised (after the modulator's limit). */
void fs_current_ctrl_update(fs_current_ctrl *cc, fs_dq u_real);
/* The same, but the integrals wind back only to u_held (between u_real and
 * the reference): the excess over u_real they keep is an outer loop's
 * input (flux weakening, fs_fw_hold); the predictor takes u_real. */
void fs_current_ctrl_update_held(fs_current_ctrl *cc, fs_dq u_real, fs_dq u_held);

#endif /* FS_CURRENT_CTRL_H */
