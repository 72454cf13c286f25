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
 * K_MAG 2.3: the voltage (beyond R i) more than 2.3 times what the loops'
 *   speed can ask of the machine, |w_hat| (psi_f + L |i|), plus twice the
 *   error bound and what the current's rate takes, L |di/dt|: a magnet flux
 *   or inductance off by x2 gives at most 2; 15 % above it.
 * U_FLOOR 0.01: 1 % of the dc link added to the voltage error bound: what
 *   the model leaves out beside the parameters (the modulator's and the
 *   sampling's timing, the carrier's leak into the fundamental), so that
 *   at standstill with no current the back-EMF is not judged on nothing.
 * K_MECH 1.2: a pi-off estimate implies a load of 2 T_ref + T_L, about 2
 *   T_max once its speed loop saturates. On track the implied load is the
 *   load, within T_max for a drive that can hold it; an inertia off by x2
 *   turns it into 2 T_L - T_ref at most (J_hat = 2 J), still within T_max
 *   for T_ref and T_L within it. 1.2 T_max: 20 % above what a tracking
 *   drive shows, below what a reversed torque does.
 * K_CUR 0.4: the current loops' error averaged over tau stays a small part
 *   of i_max on track (a step of i_max leaves i_max / (bw_current tau), 7 %
 *   at 3000 rad/s and 5 ms); 40 % of i_max is a loop that no longer holds.
 * E_USE 3 E_err: the back-EMF is judged where the loops' speed makes it 3
 *   times the voltage the model leaves out; below, the mechanics are.
 * WARM 2 tau: the low-passes start from 0 when the checks come on; before
 *   two time constants (86 % of a step) no residual is reported.
 * The constants were set from these bounds, then checked on the campaign
 * (fullspeed.lock_campaign): thresholds 1.3 times lower everywhere added
 * detections there but also false alarms on healthy runs (zoo machines
 * near their own limits), 1.6 times lower more so. */
#define FS_MONITOR_E_USE 3.0f
#define FS_MONITOR_K_MAG 2.3f
#define FS_MONITOR_U_FLOOR 0.01f
#define FS_MONITOR_WARM 2.0f

fs_status fs_monitor_init(fs_monitor *m, const fs_monitor_config *cfg)
{
    if (!m || !cfg) return FS_ERR_NULL;
    if (!fs_pos(cfg->Ts)) return FS_ERR_TS;
    if (cfg->delay < 0 || cfg->delay > 2) return FS_ERR_PARAM;
    if (!fs_nonneg(cfg->R_s)) return FS_ERR_RS;
    if (!fs_pos(cfg->L_d)) return FS_ERR_LD;
    if (!fs_pos(cfg->L_q)) return FS_ERR_LQ;
    if (!fs_nonneg(cfg->psi_f)) return FS_ERR_PSI_F;
    if (cfg->pole_pairs < 1) return FS_ERR_POLE_PAIRS;
    if (!fs_nonneg(cfg->J)) return FS_ERR_J;
    if (!fs_nonneg(cfg->B) || !fs_nonneg(cfg->k_dead) || !(cfg->k_dead < 0.5f)) return FS_ERR_PARAM;
    if (!fs_nonneg(cfg->T_max)) return FS_ERR_LIMIT;
    if (!fs_pos(cfg->i_max)) return FS_ERR_I_MAX;
    if (!(cfg->tau >= cfg->Ts) || !fs_fin(cfg->tau)) return FS_ERR_LIMIT;
    m->cfg = *cfg;
    m->b = 1.0f - expf(-cfg->Ts / cfg->tau);
    fs_monitor_reset(m);
    return FS_OK;
}

void fs_monitor_reset(fs_monitor *m)
{
    m->started = false;
    m->k = 0;
    m->i_prev.alpha = m->i_prev.beta = 0.0f;
    m->u_q1 = m->u_q2 = m->i_prev;
    m->e_d = m->e_q = m->v_mag = m->di_mag = 0.0f;
    m->w_f = m->T_f = m->id_f = m->i_f = m->ierr_f = 0.0f;
    m->r_dir = m->r_mag = m->r_mech = m->r_cur = 0.0f;
    m->E_hat = m->E_err = m->T_L_hat = m->T_L_abs = 0.0f;
}

/* The extended EMF over the period that ended at this sample, alpha-beta. */
static fs_ab monitor_emf(const fs_monitor *m, const fs_monitor_in *in)
{
    const fs_monitor_config *c = &m->cfg;
    /* the voltage that acted over it was computed `delay` + 1 steps ago */
    const fs_ab u = c->delay == 0 ? m->u_q1 : m->u_q2;
    const fs_ab im = {0.5f * (in->i.alpha + m->i_prev.alpha), 0.5f * (in->i.beta + m->i_prev.beta)};
    const float kL = c->L_d / c->Ts, kx = in->w * (c->L_d - c->L_q);
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
    const float w_prev = m->w_f;
    if (!m->started) {
        /* the speed and torque filters start where they are: no false
         * acceleration; the EMF needs one period of history first */
        m->started = true;
        m->w_f = in->w;
        m->T_f = in->T_ref;
        m->i_prev = in->i;
        m->u_q1 = m->u_q2 = in->u_next;
        return 0.0f;
    }
    /* back-EMF in the loops' frame, at the period's middle */
    const fs_ab e_ab = monitor_emf(m, in);
    /* the voltage beyond the resistance's, as a magnitude (no derivative:
     * the carrier's leak and the noise in di/dt would bias it), and the
     * current's rate, which bounds what the inductance takes */
    {
        const fs_ab u = c->delay == 0 ? m->u_q1 : m->u_q2;
        const float va = u.alpha - c->R_s * 0.5f * (in->i.alpha + m->i_prev.alpha);
        const float vb = u.beta - c->R_s * 0.5f * (in->i.beta + m->i_prev.beta);
        const float da = in->i.alpha - m->i_prev.alpha, db = in->i.beta - m->i_prev.beta;
        m->v_mag += b * (sqrtf(va * va + vb * vb) - m->v_mag);
        m->di_mag += b * (sqrtf(da * da + db * db) / c->Ts - m->di_mag);
    }
    const float th = in->theta - 0.5f * in->w * c->Ts;
    const fs_dq e = fs_park(e_ab, fs_cosf(th), fs_sinf(th));
    const fs_dq i_dq = fs_park(in->i, fs_cosf(in->theta), fs_sinf(in->theta));
    m->e_d += b * (e.d - m->e_d);
    m->e_q += b * (e.q - m->e_q);
    m->w_f += b * (in->w - m->w_f);
    m->T_f += b * (in->T_ref - m->T_f);
    m->id_f += b * (i_dq.d - m->id_f);
    m->i_f += b * (sqrtf(i_dq.d * i_dq.d + i_dq.q * i_dq.q) - m->i_f);
    m->ierr_f += b * (sqrtf(in->i_err.d * in->i_err.d + in->i_err.q * in->i_err.q) - m->ierr_f);
    m->i_prev = in->i;
    m->u_q2 = m->u_q1;
    m->u_q1 = in->u_next;
    m->k++;

    const float aw = fabsf(m->w_f);
    const float s = m->w_f < 0.0f ? -1.0f : 1.0f;
    m->E_hat = fs_maxf(aw * (c->psi_f + (c->L_d - c->L_q) * m->id_f), 0.0f);
    m->E_err = (c->k_dead + FS_MONITOR_U_FLOOR) * in->u_dc + c->R_s * m->i_f + aw * fs_maxf(c->L_d, c->L_q) * fabsf(m->id_f);
    const float pp = (float)c->pole_pairs;
    /* d(w_f)/dt: the low-passed speed's own derivative, s / (tau s + 1) w */
    const float T_L = m->T_f - (c->J / pp) * (m->w_f - w_prev) / c->Ts - (c->B / pp) * m->w_f;
    m->T_L_hat += b * (T_L - m->T_L_hat);   /* a second pole: the speed's noise differentiated */
    /* its size, averaged: an estimate whose speed swings both ways implies
     * loads of both signs, which would cancel in T_L_hat itself */
    m->T_L_abs += b * (fabsf(m->T_L_hat) - m->T_L_abs);
    if ((float)m->k < FS_MONITOR_WARM * c->tau / c->Ts) return 0.0f;

    const float p = s * m->e_q;
    /* where the loops' speed makes an EMF that stands out, one that does not
     * show in their frame is a loss; anywhere, one that points backwards
     * beyond the error bound is */
    const bool emf = m->E_hat >= FS_MONITOR_E_USE * m->E_err;
    const float den = m->E_hat + m->E_err;
    m->r_dir = den > 0.0f ? fs_maxf(1.0f + ((emf ? FS_MONITOR_K_DIR * m->E_hat : 0.0f) - m->E_err - p) / den, 0.0f) : 0.0f;
    m->r_mech = emf || !(c->J > 0.0f && c->T_max > 0.0f) ? 0.0f : m->T_L_abs / (FS_MONITOR_K_MECH * c->T_max);
    m->r_cur = m->ierr_f / (FS_MONITOR_K_CUR * c->i_max);
    const float L = fs_maxf(c->L_d, c->L_q);
    m->r_mag = m->v_mag / (FS_MONITOR_K_MAG * aw * (c->psi_f + L * m->i_f) + 2.0f * m->E_err + L * m->di_mag);
    return fs_maxf(fs_maxf(m->r_dir, m->r_mag), fs_maxf(m->r_mech, m->r_cur));
}
