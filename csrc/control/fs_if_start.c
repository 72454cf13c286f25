#include "fs_if_start.h"
#include "fs_math.h"

FS_COLD fs_status fs_if_start_init(fs_if_start *s, const fs_if_start_config *cfg)
{
    if (!s || !cfg) { return FS_ERR_NULL; }
    if (!fs_pos(cfg->Ts)) { return FS_ERR_TS; }
    if (!fs_pos(cfg->i_start)) { return FS_ERR_I_MAX; }
    if (!fs_pos(cfg->a_start) || !fs_pos(cfg->w_handover)) { return FS_ERR_PARAM; }
    if (!fs_nonneg(cfg->R_s)) { return FS_ERR_RS; }
    if (!fs_pos(cfg->L)) { return FS_ERR_LD; }
    if (!fs_nonneg(cfg->psi_f)) { return FS_ERR_PSI_F; }
    if (!fs_nonneg(cfg->r_damp)) { return FS_ERR_PARAM; }
    if (cfg->r_damp > 0.0f && !(fs_pos(cfg->w_swing) && cfg->w_swing * cfg->Ts <= 0.1f)) { return FS_ERR_BANDWIDTH; }
    if (!fs_fin(cfg->i_max) || !(cfg->i_max >= cfg->i_start)) { return FS_ERR_I_MAX; }
    if (!fs_nonneg(cfg->t_handover)) { return FS_ERR_PARAM; }
    s->cfg = *cfg;
    s->a_hp = fs_exp_pole(-0.25f * cfg->w_swing * cfg->Ts);
    s->b_lp = -expm1f(-fs_minf(4.0f * cfg->w_swing * cfg->Ts, 0.1f));
    fs_if_start_reset(s, 0.0f, 0.0f);
    return FS_OK;
}

void fs_if_start_reset(fs_if_start *s, float theta, float w)
{
    s->theta = theta;
    s->w = w;
    s->i_prev.alpha = s->i_prev.beta = 0.0f;
    s->primed = false;
    s->x_prev.d = s->x_prev.q = s->hp.d = s->hp.q = s->lp.d = s->lp.q = 0.0f;
    s->t_held = 0.0f;
    s->timed_out = false;
}

/* The damping's current: the EMF over the period that ended now, less the
 * frame's own, band-passed, over r_damp (header). */
static fs_dq if_damping(fs_if_start *s, fs_ab i_ab, fs_ab u_ab)
{
    const fs_if_start_config *c = &s->cfg;
    if (!s->primed) {   /* no current before the first sample: no derivative yet */
        s->i_prev = i_ab;
        s->primed = true;
    }
    fs_ab e = {u_ab.alpha - 0.5f * c->R_s * (i_ab.alpha + s->i_prev.alpha) - c->L * (i_ab.alpha - s->i_prev.alpha) / c->Ts,
               u_ab.beta - 0.5f * c->R_s * (i_ab.beta + s->i_prev.beta) - c->L * (i_ab.beta - s->i_prev.beta) / c->Ts};
    s->i_prev = i_ab;
    const float th = s->theta - 0.5f * c->Ts * s->w;   /* the period's middle */
    fs_dq x = fs_park(e, fs_cosf(th), fs_sinf(th));
    /* less the EMF the frame's own speed makes along the EMF's direction (the
     * load angle turns it away from q), or along q where the rotor turns the
     * other way */
    const float m = sqrtf(x.d * x.d + x.q * x.q), e_f = fabsf(s->w) * c->psi_f;
    if (x.q * s->w > 0.0f && m > 0.0f) {
        x.d -= e_f * x.d / m;
        x.q -= e_f * x.q / m;
    } else {
        x.q -= s->w * c->psi_f;
    }
    s->hp.d = s->a_hp * (s->hp.d + x.d - s->x_prev.d);
    s->hp.q = s->a_hp * (s->hp.q + x.q - s->x_prev.q);
    s->x_prev = x;
    s->lp.d += s->b_lp * (s->hp.d - s->lp.d);
    s->lp.q += s->b_lp * (s->hp.q - s->lp.q);
    return (fs_dq){-s->lp.d / c->r_damp, -s->lp.q / c->r_damp};
}

fs_dq fs_if_start_step(fs_if_start *s, float w_target, fs_ab i_ab, fs_ab u_ab)
{
    const fs_if_start_config *c = &s->cfg;
    fs_dq i = {c->i_start, 0.0f};
    if (c->r_damp > 0.0f) {
        const fs_dq di = if_damping(s, i_ab, u_ab);
        i.d += di.d;
        i.q = di.q;
        const float m = sqrtf(i.d * i.d + i.q * i.q);
        if (m > c->i_max) {
            i.d *= c->i_max / m;
            i.q *= c->i_max / m;
        }
    }
    const float target = fs_clamp_sym(w_target, c->w_handover);
    s->w += fs_clamp_sym(target - s->w, c->a_start * c->Ts);
    s->theta = fs_wrap_pi(s->theta + c->Ts * s->w);
    if (fabsf(s->w) >= 0.999f * c->w_handover) {
        s->t_held += c->Ts;
        s->timed_out = c->t_handover > 0.0f && s->t_held > c->t_handover;
    }
    return i;
}
