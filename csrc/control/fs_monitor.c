#include "fs_monitor.h"
#include "fs_math.h"
#include "fs_transforms.h"

/* Design constants (fs_monitor.h), each with its reason:
 * K_DIR 0.25: p < 0.25 E_hat - E_err. With the magnet flux exact an angle
 *   error past acos 0.25 = 76 el.deg; with psi_f off by x2 either way (E_hat
 *   = 2 or 0.5 E_ext) past 60 or 83 el.deg: never for the 30-45 el.deg a
 *   tracking estimator swings in transients, and a flag up to 30 el.deg
 *   before the truth's 90 gives the 20 ms net count a head start on the
 *   filters' lag (tau).
 * U_FLOOR 0.01: 1 % of the dc link added to the voltage error bound: what
 *   the model leaves out beside the parameters (the modulator's and the
 *   sampling's timing, the carrier's leak into the fundamental), so that
 *   at standstill with no current the back-EMF is not judged on nothing.
 * E_USE 3 E_err: the back-EMF's direction is judged where the loops' speed
 *   makes it 3 times the voltage the model leaves out; below, the
 *   mechanics are.
 * E_SLIP 1 E_err: the slip is judged where the EMF measured is at least
 *   the error bound: the errors, which stand still in the loops' frame while
 *   they hold their current, then weigh at most as much as the EMF and only
 *   pull the turn measured towards 0 (never past the bound).
 * SLIP pi / t_lost: a slip that turns the angle error by half a turn
 *   within the lock counter's time (header, 2.).
 * PRE 1/8: the slip's pre-filter corner at an eighth of the carrier's
 *   frequency (its leak 8 x, two poles 65 x down); without injection at an
 *   eighth of the Nyquist frequency (noise only). A carrier's leak is no
 *   error that stands still: it turns at the carrier's frequency, and where
 *   it weighs against the EMF judged its own turn enters x_f. As the
 *   injection comes back in a reversal its filters settle and pass the
 *   carrier into the fundamental current: at 1/4 (17 x down) the slip went
 *   to 2.1 within 12 ms of the restart at 96 rpm on an EMF of 2.2 V (zoo
 *   machine 2 on its identified map, B-MAPID; the true map's run reached
 *   0.94), at 1/8 it stays below 1. A slip's own rate passes the filter
 *   unchanged; the corner delays it by about 2 / (PRE w_h), 3 ms at 1 kHz.
 * K_MECH 1.2: a pi-off estimate implies a load of 2 T_ref + T_L (J exact),
 *   (1 + k) T_ref + k T_L with the inertia off by k = J_hat / J, about
 *   2 T_max once its speed loop saturates. On track the implied load is
 *   (1 - k) T_ref + k T_L: the load for k = 1, and for k in [0.5, 2] within
 *   T_max while the speed loop holds T_ref near T_L (beyond it only for
 *   the 1 / bw_speed its answer to a load step takes, which the 20 ms net
 *   count does not reach). 1.2 T_max: 20 % above what a tracking drive
 *   shows, below what a reversed torque does.
 * K_CUR 0.4: the current loops' error averaged over tau stays a small part
 *   of i_max on track (a step of i_max leaves i_max / (bw_current tau), 7 %
 *   at 3000 rad/s and 5 ms); 40 % of i_max is a loop that no longer holds.
 * K_USPD 0.5: a voltage short holds 5.'s error where the speed's voltage
 *   could be half the modulator's linear limit (u_dc / sqrt 3): there the
 *   limit may be the speed's, which flux weakening answers (SyR-e's THOR
 *   short for 20 ms at 4,147 rpm, header 5.). Below, the other half drives a
 *   current step, which closes within the few ms the low-pass and the 20 ms
 *   net count ride out; a short that lasts is not the speed's.
 * JUMP pi/2 over t_lost / 2: the truth's 90 el.deg (header, 4.); the leak
 *   over half the lock time holds a hand-over's turn (a blend crosses its
 *   band in a few ms) and forgets a speed state's slow errors.
 * E_LIM 1e18 V: the EMF the slip's products take is clamped there, so that
 *   their squares stay finite in float32 (3.4e38) whatever a diverged
 *   speed estimate puts into the model's rotation term; any EMF beyond
 *   the link's voltage already makes the residual large.
 * K_EXC 0.1: the torque's sign is judged where the torque commanded moved
 *   by a tenth of T_max within t_lost (its rate's rms times t_lost): the
 *   answer looked for is then 0.1 T_max / J of acceleration, which the
 *   estimate's speed noise through the second derivative and the small
 *   variations of a load do not reverse over t_lost (an unknown load's
 *   steps are the sign test's and the EMF gate's, header 6.).
 * WARM 2 tau: the low-passes start from 0 when the checks come on; before
 *   two time constants (86 % of a step) no residual is reported.
 * The constants were set from these bounds, then checked on the campaign
 * (fullspeed.workflows.lock_campaign): on its 236 healthy runs that kept lock the
 * largest r_dir, r_mech, r_cur were 0.73, 0.60, 0.65 and |jump| 0.52 rad;
 * r_slip and r_sign went past 1 for a few ms (1.32 and 1.45 at the most,
 * zoo machine 16 starting under load), and the lock counter reached 7.4 ms
 * of its 20 (two runs on zoo machine 11, which came within 79 and 88
 * el.deg of losing the rotor before an overcurrent stop, were flagged). */
#define FS_MONITOR_E_USE 3.0f
#define FS_MONITOR_E_SLIP 1.0f
#define FS_MONITOR_PRE 0.125f
#define FS_MONITOR_U_FLOOR 0.01f
#define FS_MONITOR_WARM 2.0f
#define FS_MONITOR_K_USPD 0.5f
#define FS_MONITOR_E_LIM 1e18f

FS_COLD fs_status fs_monitor_init(fs_monitor *m, const fs_monitor_config *cfg)
{
    if (!m || !cfg) { return FS_ERR_NULL; }
    if (!fs_pos(cfg->Ts)) { return FS_ERR_TS; }
    if (cfg->delay < 0 || cfg->delay > 2) { return FS_ERR_PARAM; }
    if (!fs_nonneg(cfg->R_s)) { return FS_ERR_RS; }
    if (!fs_pos(cfg->L_d)) { return FS_ERR_LD; }
    if (!fs_pos(cfg->L_q)) { return FS_ERR_LQ; }
    if (!fs_nonneg(cfg->psi_f)) { return FS_ERR_PSI_F; }
    if (cfg->pole_pairs < 1) { return FS_ERR_POLE_PAIRS; }
    if (!fs_nonneg(cfg->J)) { return FS_ERR_J; }
    if (!fs_nonneg(cfg->B) || !fs_nonneg(cfg->k_dead) || !(cfg->k_dead < 0.5f)) { return FS_ERR_PARAM; }
    if (!fs_nonneg(cfg->T_max)) { return FS_ERR_LIMIT; }
    if (!fs_pos(cfg->i_max)) { return FS_ERR_I_MAX; }
    if (!(cfg->tau >= cfg->Ts) || !fs_fin(cfg->tau)) { return FS_ERR_LIMIT; }
    if (!(cfg->t_lost >= 4.0f * cfg->Ts) || !fs_fin(cfg->t_lost)) { return FS_ERR_LIMIT; }
    if (!fs_nonneg(cfg->w_h)) { return FS_ERR_BANDWIDTH; }
    m->cfg = *cfg;
    m->b = -expm1f(-cfg->Ts / cfg->tau);
    m->a_s = -expm1f(-FS_MONITOR_PRE * (cfg->w_h > 0.0f ? cfg->w_h : FS_PI / cfg->Ts) * cfg->Ts);
    m->x_max = fs_tanf(FS_PI * cfg->Ts / cfg->t_lost);
    m->a_j = fs_exp_pole(-2.0f * cfg->Ts / cfg->t_lost);
    m->b_c = -expm1f(-cfg->Ts / cfg->t_lost);
    m->k_y = cfg->J / ((float)cfg->pole_pairs * cfg->tau);
    const float x_exc = FS_MONITOR_K_EXC * cfg->T_max * cfg->tau / cfg->t_lost;
    m->c_exc = x_exc * x_exc;
    m->k_L = cfg->L_d / cfg->Ts;
    m->L_dq = cfg->L_d - cfg->L_q;
    m->L_max = fs_maxf(cfg->L_d, cfg->L_q);
    m->J_p = cfg->J / (float)cfg->pole_pairs;
    m->B_p = cfg->B / (float)cfg->pole_pairs;
    m->u_err = cfg->k_dead + FS_MONITOR_U_FLOOR;
    m->psi_spd = (cfg->psi_f + (m->L_max * cfg->i_max)) * (FS_SQRT3 / FS_MONITOR_K_USPD);
    /* k < n_warm as (float)k < FS_MONITOR_WARM tau / Ts was; at most 2^30 */
    const float k_warm = FS_MONITOR_WARM * cfg->tau / cfg->Ts;
    m->n_warm = k_warm < 1073741824.0f ? fs_ceil_int(k_warm) : 1073741824;
    m->T_mech = FS_MONITOR_K_MECH * cfg->T_max;
    m->i_cur = FS_MONITOR_K_CUR * cfg->i_max;
    fs_monitor_reset(m);
    return FS_OK;
}

void fs_monitor_reset(fs_monitor *m)
{
    m->started = false;
    m->k = 0;
    m->i_prev.alpha = m->i_prev.beta = 0.0f;
    m->u_q1 = m->u_q2 = m->i_prev;
    m->e_s1.d = m->e_s1.q = m->e_s2.d = m->e_s2.q = 0.0f;
    m->e_d = m->e_q = m->x_f = m->p_f = 0.0f;
    m->w_f = m->T_f = m->id_f = m->i_f = m->ierr_f = 0.0f;
    m->iq_f = 0.0f;
    m->w_f2 = m->w_f3 = m->T_f2 = m->T_f3 = m->c_xy = m->c_xx = 0.0f;
    m->th_prev = m->w_prev = m->jump = 0.0f;
    m->jumped = false;
    m->r_dir = m->r_slip = m->r_mech = m->r_cur = m->r_sign = 0.0f;
    m->E_hat = m->E_err = m->T_L_hat = 0.0f;
}

/* The extended EMF over the period that ended at this sample, alpha-beta. */
static fs_ab monitor_emf(const fs_monitor *m, const fs_monitor_in *in)
{
    const fs_monitor_config *c = &m->cfg;
    /* the voltage that acted over it was computed `delay` + 1 steps ago */
    const fs_ab u = c->delay == 0 ? m->u_q1 : m->u_q2;
    const fs_ab im = {0.5f * (in->i.alpha + m->i_prev.alpha), 0.5f * (in->i.beta + m->i_prev.beta)};
    const float kL = m->k_L, kx = in->w * m->L_dq;
    fs_ab e;
    e.alpha = u.alpha - c->R_s * im.alpha - kL * (in->i.alpha - m->i_prev.alpha) - kx * im.beta;
    e.beta = u.beta - c->R_s * im.beta - kL * (in->i.beta - m->i_prev.beta) + kx * im.alpha;
    return e;
}

float fs_monitor_step(fs_monitor *m, const fs_monitor_in *in)
{
    const fs_monitor_config *c = &m->cfg;
    if (!in->on) {
        fs_monitor_reset(m);
        return 0.0f;
    }
    const float b = m->b;
    const float w_f_prev = m->w_f;
    if (!m->started) {
        /* the speed and torque filters start where they are: no false
         * acceleration; the EMF needs one period of history first */
        m->started = true;
        m->w_f = m->w_f2 = m->w_f3 = in->w;
        m->th_prev = in->theta;
        m->w_prev = in->w;
        m->T_f = m->T_f2 = m->T_f3 = in->T_ref;
        m->iq_f = in->i_dq.q;
        m->i_prev = in->i;
        m->u_q1 = m->u_q2 = in->u_next;
        return 0.0f;
    }
    /* back-EMF in the loops' frame at the period's middle: their Park
     * transform turned back by dl = w Ts / 2 (second order in dl) */
    const fs_dq e0 = fs_park(monitor_emf(m, in), in->cos_t, in->sin_t);
    const float dl = 0.5f * in->w * c->Ts, cl = 1.0f - 0.5f * dl * dl;
    const fs_dq e = {fs_clamp_sym(cl * e0.d - dl * e0.q, FS_MONITOR_E_LIM),
                     fs_clamp_sym(cl * e0.q + dl * e0.d, FS_MONITOR_E_LIM)};
    /* its turn over one period in that frame: cross and dot products with
     * the last period's, low-passed: x_f / p_f = tan(slip Ts) */
    const float a = m->a_s;
    m->e_s1.d += a * (e.d - m->e_s1.d);
    m->e_s1.q += a * (e.q - m->e_s1.q);
    const fs_dq ep = m->e_s2;
    m->e_s2.d += a * (m->e_s1.d - ep.d);
    m->e_s2.q += a * (m->e_s1.q - ep.q);
    m->x_f += b * (ep.d * m->e_s2.q - ep.q * m->e_s2.d - m->x_f);
    m->p_f += b * (ep.d * m->e_s2.d + ep.q * m->e_s2.q - m->p_f);
    const fs_dq i_dq = in->i_dq;
    m->e_d += b * (e.d - m->e_d);
    m->e_q += b * (e.q - m->e_q);
    /* the loops' angle's turn beyond their speed (trapezoid), leaky; the
     * difference of two angles in (-pi, pi] needs one turn at most */
    float dth = in->theta - m->th_prev;
    dth += dth > FS_PI ? -FS_TWO_PI : (dth <= -FS_PI ? FS_TWO_PI : 0.0f);
    m->jump = m->a_j * m->jump + dth - 0.5f * (in->w + m->w_prev) * c->Ts;
    m->th_prev = in->theta;
    m->w_prev = in->w;
    m->w_f += b * (in->w - m->w_f);
    m->T_f += b * (in->T_ref - m->T_f);
    /* the torque's sign (6.): its rate against the inertial torque's, both
     * through three low-passes */
    m->w_f2 += b * (m->w_f - m->w_f2);
    m->w_f3 += b * (m->w_f2 - m->w_f3);
    m->T_f2 += b * (m->T_f - m->T_f2);
    m->T_f3 += b * (m->T_f2 - m->T_f3);
    const float x = m->T_f2 - m->T_f3;
    const float y = m->k_y * (m->w_f - 2.0f * m->w_f2 + m->w_f3);
    m->c_xy += m->b_c * (x * y - m->c_xy);
    m->c_xx += m->b_c * (x * x - m->c_xx);
    m->id_f += b * (i_dq.d - m->id_f);
    const float diq = b * (i_dq.q - m->iq_f);   /* the low-passed q current's change this period */
    m->iq_f += diq;
    m->i_f += b * (sqrtf(i_dq.d * i_dq.d + i_dq.q * i_dq.q) - m->i_f);
    if (!in->u_limited || ((fabsf(m->w_f) * m->psi_spd) < in->u_dc)) {   /* header, 5. */
        m->ierr_f += b * (sqrtf(in->i_err.d * in->i_err.d + in->i_err.q * in->i_err.q) - m->ierr_f);
    }
    m->i_prev = in->i;
    m->u_q2 = m->u_q1;
    m->u_q1 = in->u_next;
    if (m->k < m->n_warm) { m->k++; }

    const float aw = fabsf(m->w_f);
    const float s = m->w_f < 0.0f ? -1.0f : 1.0f;
    m->E_hat = fs_maxf(aw * (c->psi_f + m->L_dq * m->id_f), 0.0f);
    const float e_iq = m->L_dq * diq / c->Ts;   /* (L_d - L_q) di_q/dt, low-passed as e_q (header, 1.) */
    m->E_err = m->u_err * in->u_dc + c->R_s * m->i_f + aw * m->L_max * fabsf(m->id_f) + fabsf(e_iq);
    /* d(w_f)/dt: the low-passed speed's own derivative, s / (tau s + 1) w */
    const float T_L = m->T_f - m->J_p * (m->w_f - w_f_prev) / c->Ts - m->B_p * m->w_f;
    m->T_L_hat += b * (T_L - m->T_L_hat);   /* a second pole: the speed's noise differentiated */
    if (m->k < m->n_warm) { return 0.0f; }
    m->jumped = m->jumped || fabsf(m->jump) > 0.5f * FS_PI;

    const float p = s * (m->e_q + e_iq);
    /* where the loops' speed makes an EMF that stands out, one that does not
     * show in their frame is a loss; anywhere, one that points backwards
     * beyond the error bound is */
    const bool emf = m->E_hat >= FS_MONITOR_E_USE * m->E_err;
    const float den = m->E_hat + m->E_err;
    m->r_dir = den > 0.0f ? fs_maxf(1.0f + ((emf ? FS_MONITOR_K_DIR * m->E_hat : 0.0f) - m->E_err - p) / den, 0.0f) : 0.0f;
    const bool mech = !emf && c->J > 0.0f && c->T_max > 0.0f;
    m->r_mech = mech ? fabsf(m->T_L_hat) / m->T_mech : 0.0f;
    m->r_sign = mech && p < 0.0f && m->c_xx >= m->c_exc ? 1.0f - m->c_xy / m->c_xx : 0.0f;
    m->r_cur = m->ierr_f / m->i_cur;
    /* the EMF's turn in the loops' frame, judged where the EMF measured
     * (its power p_f, whatever the loops' speed says) reaches the bound */
    const float E_g = FS_MONITOR_E_SLIP * m->E_err;
    m->r_slip = m->p_f > E_g * E_g ? fabsf(m->x_f) / (m->x_max * m->p_f) : 0.0f;
    return fs_maxf(fs_maxf(fs_maxf(m->r_dir, m->r_slip), fs_maxf(m->r_mech, m->r_cur)), m->r_sign);
}
