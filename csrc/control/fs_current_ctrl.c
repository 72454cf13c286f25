#include "fs_current_ctrl.h"
#include "fs_math.h"

/* L di/dt = u - R i sampled with a zero-order hold: i+ = a i + b u */
static void sampled_plant(float Ts, float L, float R, float *a, float *b)
{
    float r = -expm1f(-R * Ts / L);  /* 1 - a, exact when small */
    *a = 1.0f - r;
    *b = (R > 0.0f && r > 0.0f) ? r / R : Ts / L;
}

/* Explicit gains (k_p > 0) or the design from the bandwidth. */
static FS_COLD fs_status design_axis(fs_pi *pi, float Ts, float L, float R, float alpha, float k_p, float k_i)
{
    const fs_pi_config c = {Ts, k_p, k_p, k_i, 0.0f};
    /* limited as a vector by the modulator, see fs_current_ctrl_update */
    return k_p > 0.0f ? fs_pi_init(pi, &c) : fs_pi_design_init(pi, Ts, L, R, alpha, 0.0f);
}

/* One axis of fs_current_ctrl_internal_model (fs_current_ctrl.h): alpha L
 * and alpha R_s when alpha Ts is small. */
static void internal_model_axis(float Ts, float L, float R, float alpha, float *k_p, float *k_i)
{
    float a, b;
    sampled_plant(Ts, L, R, &a, &b);
    *k_p = -expm1f(-alpha * Ts) / b;
    *k_i = *k_p * (1.0f - a) / Ts;
}

void fs_current_ctrl_internal_model(fs_current_ctrl_config *cfg)
{
    if (!cfg) { return; }
    internal_model_axis(cfg->Ts, cfg->L_d, cfg->R_s, cfg->bandwidth, &cfg->k_p_d, &cfg->k_i_d);
    internal_model_axis(cfg->Ts, cfg->L_q, cfg->R_s, cfg->bandwidth, &cfg->k_p_q, &cfg->k_i_q);
}

FS_COLD fs_status fs_current_ctrl_init(fs_current_ctrl *cc, const fs_current_ctrl_config *cfg)
{
    if (!cc || !cfg) { return FS_ERR_NULL; }
    if (!fs_pos(cfg->Ts)) { return FS_ERR_TS; }
    if (!fs_nonneg(cfg->R_s)) { return FS_ERR_RS; }
    if (!fs_pos(cfg->L_d)) { return FS_ERR_LD; }
    if (!fs_pos(cfg->L_q)) { return FS_ERR_LQ; }
    if (!fs_nonneg(cfg->psi_f)) { return FS_ERR_PSI_F; }
    if (!(cfg->bandwidth > 0.0f) || !(cfg->bandwidth * cfg->Ts <= 1.0f)) { return FS_ERR_BANDWIDTH; }
    const bool explicit_d = cfg->k_p_d != 0.0f || cfg->k_i_d != 0.0f;
    const bool explicit_q = cfg->k_p_q != 0.0f || cfg->k_i_q != 0.0f;
    if (explicit_d != explicit_q) { return FS_ERR_PARAM; }
    if (explicit_d && !(fs_pos(cfg->k_p_d) && fs_nonneg(cfg->k_i_d) && fs_pos(cfg->k_p_q) && fs_nonneg(cfg->k_i_q))) {
        return FS_ERR_PARAM;
    }
    cc->cfg = *cfg;
    sampled_plant(cfg->Ts, cfg->L_d, cfg->R_s, &cc->a_d, &cc->b_d);
    sampled_plant(cfg->Ts, cfg->L_q, cfg->R_s, &cc->a_q, &cc->b_q);
    fs_status st = design_axis(&cc->pi_d, cfg->Ts, cfg->L_d, cfg->R_s, cfg->bandwidth, cfg->k_p_d, cfg->k_i_d);
    if (st != FS_OK) { return st; }
    st = design_axis(&cc->pi_q, cfg->Ts, cfg->L_q, cfg->R_s, cfg->bandwidth, cfg->k_p_q, cfg->k_i_q);
    if (st != FS_OK) { return st; }
    cc->iso_asked = false;
    cc->iso = false;
    cc->L_d_pi = cfg->L_d;
    cc->L_q_pi = cfg->L_q;
    fs_current_ctrl_reset(cc);
    return FS_OK;
}

FS_COLD void fs_current_ctrl_reset(fs_current_ctrl *cc)
{
    fs_pi_reset(&cc->pi_d);
    fs_pi_reset(&cc->pi_q);
    cc->ref.d = cc->ref.q = 0.0f;
    cc->meas = cc->ref;
    cc->u = cc->ref;
    cc->u_ff = cc->ref;
    cc->u_prev = cc->ref;
    cc->map = false;   /* until the drive gives a map's values (fs_current_ctrl_set_flux) */
    cc->psi_ref_on = false;
    cc->on_flux = false;
    cc->i0 = cc->ref;
}

FS_COLD void fs_current_ctrl_set_isotropic(fs_current_ctrl *cc, bool on)
{
    const fs_current_ctrl_config *c = &cc->cfg;
    const bool designed = (c->k_p_d == 0.0f) && (c->k_i_d == 0.0f);
    const bool iso = on && designed;
    cc->iso_asked = on;
    if (iso != cc->iso) {
        const float L_min = fs_minf(c->L_d, c->L_q);
        const float integ_d = cc->pi_d.integ;
        const float integ_q = cc->pi_q.integ;
        cc->iso = iso;
        cc->L_d_pi = iso ? L_min : c->L_d;
        cc->L_q_pi = iso ? L_min : c->L_q;
        sampled_plant(c->Ts, cc->L_d_pi, c->R_s, &cc->a_d, &cc->b_d);
        sampled_plant(c->Ts, cc->L_q_pi, c->R_s, &cc->a_q, &cc->b_q);
        /* checked at init with the larger inductances: the smaller one's gains are finite too */
        (void)design_axis(&cc->pi_d, c->Ts, cc->L_d_pi, c->R_s, c->bandwidth, 0.0f, 0.0f);
        (void)design_axis(&cc->pi_q, c->Ts, cc->L_q_pi, c->R_s, c->bandwidth, 0.0f, 0.0f);
        cc->pi_d.integ = integ_d;
        cc->pi_q.integ = integ_q;
    }
}

void fs_current_ctrl_set_flux_ref(fs_current_ctrl *cc, fs_dq psi_ref)
{
    cc->psi_ref = psi_ref;
    cc->psi_ref_on = true;
}

void fs_current_ctrl_set_flux(fs_current_ctrl *cc, fs_dq i0, const fs_fluxmap_point *p)
{
    cc->map = true;
    cc->i0 = i0;
    cc->psi0 = p->psi;
    cc->L_dd = p->L_dd;
    cc->L_qq = p->L_qq;
    cc->L_dq = p->L_dq;
    cc->L_qd = p->L_qd;
    if (cc->iso) {   /* fs_current_ctrl_set_isotropic: the map's smaller incremental inductance on both */
        const float L_min = fs_minf(p->L_dd, p->L_qq);
        cc->s_d = L_min / cc->L_d_pi;
        cc->s_q = L_min / cc->L_q_pi;
    } else {
        cc->s_d = p->L_dd / cc->L_d_pi;
        cc->s_q = p->L_qq / cc->L_q_pi;
    }
}

/* The loops' signals on a flux map, on the currents (fs_current_ctrl.h):
 * the predictor's plant per axis at the incremental inductance, i+ = i +
 * (1 - a) / s ... with b / s; the fluxes at the measured and at the
 * predicted current from the map's linearisation; the PIs on s i (their
 * gains times s). Writes the feed-forward. */
static void map_on_currents(fs_current_ctrl *cc, fs_dq i_ref, fs_dq i, float w_e, fs_dq *r, fs_dq *y)
{
    const fs_current_ctrl_config *c = &cc->cfg;
    if (c->predict != 0) {
        const float psi_d = cc->psi0.d + cc->L_dd * (i.d - cc->i0.d), psi_q = cc->psi0.q + cc->L_qq * (i.q - cc->i0.q);
        const float v_d = cc->u_prev.d + w_e * psi_q, v_q = cc->u_prev.q - w_e * psi_d;
        const float i_d = i.d + ((cc->a_d - 1.0f) * i.d + cc->b_d * v_d) / cc->s_d;
        i.q = i.q + ((cc->a_q - 1.0f) * i.q + cc->b_q * v_q) / cc->s_q;
        i.d = i_d;
    }
    cc->u_ff.d = -w_e * (cc->psi0.q + cc->L_qq * (i.q - cc->i0.q));
    cc->u_ff.q = w_e * (cc->psi0.d + cc->L_dd * (i.d - cc->i0.d));
    r->d = cc->s_d * i_ref.d;
    r->q = cc->s_q * i_ref.q;
    y->d = cc->s_d * i.d;
    y->q = cc->s_q * i.q;
}

/* ... and on the fluxes (fs_current_ctrl_set_flux_ref): the flux at the
 * measured current from the map's linearisation with its cross terms, one
 * period ahead on the voltage equation itself, d psi / dt = u - R i - j w
 * psi (exact in the flux, whatever the inductances), and the PIs on the
 * flux over the inductance they are designed for, the magnet's flux taken
 * off d so that both stay near the currents they stand for. */
static void map_on_fluxes(fs_current_ctrl *cc, fs_dq i, float w_e, fs_dq *r, fs_dq *y)
{
    const fs_current_ctrl_config *c = &cc->cfg;
    const float di_d = i.d - cc->i0.d;
    const float di_q = i.q - cc->i0.q;
    fs_dq psi;
    psi.d = cc->psi0.d + (cc->L_dd * di_d) + (cc->L_dq * di_q);
    psi.q = cc->psi0.q + (cc->L_qd * di_d) + (cc->L_qq * di_q);
    if (c->predict != 0) {
        const float psi_d = psi.d + (c->Ts * ((cc->u_prev.d - (c->R_s * i.d)) + (w_e * psi.q)));
        psi.q += c->Ts * ((cc->u_prev.q - (c->R_s * i.q)) - (w_e * psi.d));
        psi.d = psi_d;
    }
    cc->u_ff.d = -w_e * psi.q;
    cc->u_ff.q = w_e * psi.d;
    r->d = (cc->psi_ref.d - c->psi_f) / cc->L_d_pi;
    r->q = cc->psi_ref.q / cc->L_q_pi;
    y->d = (psi.d - c->psi_f) / cc->L_d_pi;
    y->q = psi.q / cc->L_q_pi;
}

/* The step on a flux map: on the fluxes where the caller gave this step's
 * reference flux (and the loops are not the isotropic ones), else on the
 * currents. Where it changes from one to the other the integrals take the
 * change of the PIs' proportional parts, so that the output does not step
 * (the hand-over from the encoder to an estimate). */
static fs_dq current_ctrl_step_map(fs_current_ctrl *cc, fs_dq i_ref, fs_dq i, float w_e)
{
    const bool flux = cc->psi_ref_on && !cc->iso;
    fs_dq r;
    fs_dq y;
    cc->psi_ref_on = false;   /* given again for the next step, or that step is on the currents */
    if (flux) {
        map_on_fluxes(cc, i, w_e, &r, &y);
    } else {
        map_on_currents(cc, i_ref, i, w_e, &r, &y);
    }
    if (flux != cc->on_flux) {
        fs_dq r0;
        fs_dq y0;
        const fs_dq u_ff = cc->u_ff;
        if (flux) {
            map_on_currents(cc, i_ref, i, w_e, &r0, &y0);
        } else {
            map_on_fluxes(cc, i, w_e, &r0, &y0);
        }
        cc->u_ff = u_ff;
        cc->pi_d.integ += fs_pi_output(&cc->pi_d, r0.d, y0.d) - fs_pi_output(&cc->pi_d, r.d, y.d);
        cc->pi_q.integ += fs_pi_output(&cc->pi_q, r0.q, y0.q) - fs_pi_output(&cc->pi_q, r.q, y.q);
        cc->on_flux = flux;
    }
    cc->u.d = fs_pi_output(&cc->pi_d, r.d, y.d) + cc->u_ff.d;
    cc->u.q = fs_pi_output(&cc->pi_q, r.q, y.q) + cc->u_ff.q;
    cc->ref = r;
    cc->meas = y;
    return cc->u;
}

fs_dq fs_current_ctrl_step(fs_current_ctrl *cc, fs_dq i_ref, fs_dq i, float w_e)
{
    const fs_current_ctrl_config *c = &cc->cfg;
    if (FS_WITH_FLUXMAP && cc->map) { return current_ctrl_step_map(cc, i_ref, i, w_e); }
    if (c->predict != 0) {
        /* current at the next sample, from the voltage acting until then:
         * the sampled plant i+ = a i + b (u - cross-coupling), per axis */
        float v_d = cc->u_prev.d + w_e * c->L_q * i.q;
        float v_q = cc->u_prev.q - w_e * (c->L_d * i.d + c->psi_f);
        float i_d = cc->a_d * i.d + cc->b_d * v_d;
        i.q = cc->a_q * i.q + cc->b_q * v_q;
        i.d = i_d;
    }
    /* Decoupling and back-EMF feed-forward: u_d = ... - w L_q i_q,
     * u_q = ... + w (L_d i_d + psi_f). */
    cc->u_ff.d = -w_e * c->L_q * i.q;
    cc->u_ff.q = w_e * (c->L_d * i.d + c->psi_f);
    cc->u.d = fs_pi_output(&cc->pi_d, i_ref.d, i.d) + cc->u_ff.d;
    cc->u.q = fs_pi_output(&cc->pi_q, i_ref.q, i.q) + cc->u_ff.q;
    cc->ref = i_ref;
    cc->meas = i;
    return cc->u;
}

void fs_current_ctrl_update(fs_current_ctrl *cc, fs_dq u_real)
{
    fs_current_ctrl_update_held(cc, u_real, u_real);
}

void fs_current_ctrl_update_held(fs_current_ctrl *cc, fs_dq u_real, fs_dq u_held)
{
    fs_pi_update(&cc->pi_d, cc->ref.d, cc->meas.d, cc->u.d, u_held.d);
    fs_pi_update(&cc->pi_q, cc->ref.q, cc->meas.q, cc->u.q, u_held.q);
    cc->u_prev = u_real;
}
