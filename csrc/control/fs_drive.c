#include "fs_drive.h"
#include "fs_math.h"

static bool drive_starts(const fs_drive_config *c)
{
    return c->mode == FS_MODE_SPEED && c->angle_source == FS_ANGLE_SMO && c->i_start > 0.0f;
}

static bool drive_weakens(const fs_drive_config *c)
{
    return c->mode == FS_MODE_SPEED && c->fw_w_e_max > 0.0f;
}

fs_status fs_drive_init(fs_drive *drv, const fs_drive_config *cfg)
{
    if (!drv || !cfg) return FS_ERR_NULL;
    if (cfg->mode < FS_MODE_OFF || cfg->mode > FS_MODE_SPEED) return FS_ERR_MODE;
    if (cfg->angle_source < FS_ANGLE_ENCODER || cfg->angle_source > FS_ANGLE_SMO) return FS_ERR_MODE;
    if (!(cfg->Ts > 0.0f) || !(cfg->T_pwm >= cfg->Ts)) return FS_ERR_TS;
    if (!(cfg->delay >= 0.0f && cfg->delay <= 2.0f)) return FS_ERR_PARAM;
    if (cfg->pole_pairs < 1) return FS_ERR_POLE_PAIRS;
    if (!(cfg->i_max > 0.0f)) return FS_ERR_I_MAX;
    if (!(cfg->t_dead_comp >= 0.0f) || !(cfg->i_dead_band >= 0.0f)) return FS_ERR_PARAM;
    drv->cfg = *cfg;

    fs_current_ctrl_config ccc = {cfg->Ts, cfg->R_s, cfg->L_d, cfg->L_q, cfg->psi_f, cfg->bw_current,
                                  cfg->delay > 0.5f};
    fs_status st = fs_current_ctrl_init(&drv->cc, &ccc);
    if (st != FS_OK) return st;

    fs_pll_config pc = {cfg->Ts, cfg->bw_pll, 0.0f};
    st = fs_pll_init(&drv->pll, &pc);
    if (st != FS_OK) return st;

    if (cfg->angle_source == FS_ANGLE_SMO) {
        fs_smo_config oc = cfg->smo;
        oc.Ts = cfg->Ts;
        oc.R_s = cfg->R_s;
        oc.L_d = cfg->L_d;
        oc.L_q = cfg->L_q;
        oc.psi_f = cfg->psi_f;
        st = fs_smo_init(&drv->smo, &oc);
        if (st != FS_OK) return st;
    }
    if (cfg->mode == FS_MODE_SPEED) {
        fs_speed_ctrl_config scc = {cfg->Ts, cfg->J, cfg->B, cfg->bw_speed, cfg->T_max};
        st = fs_speed_ctrl_init(&drv->sc, &scc);
        if (st != FS_OK) return st;
        fs_mtpa_config mc = {cfg->L_d, cfg->L_q, cfg->psi_f, cfg->pole_pairs, cfg->i_max};
        st = fs_mtpa_init(&drv->mtpa, &mc);
        if (st != FS_OK) return st;
        if (!(cfg->fw_w_e_max >= 0.0f)) return FS_ERR_LIMIT;
        if (drive_weakens(cfg)) {
            float w_c = cfg->fw_cutoff > 0.0f ? cfg->fw_cutoff : 0.25f * cfg->bw_current / cfg->fw_gain;
            fs_fw_config fc = {cfg->Ts, cfg->L_d, cfg->fw_w_e_max, cfg->fw_gain, w_c, cfg->i_max};
            st = fs_fw_init(&drv->fw, &fc);
            if (st != FS_OK) return st;
        }
    }
    if (!(cfg->i_start >= 0.0f) || cfg->i_start > cfg->i_max) return FS_ERR_I_MAX;
    if (cfg->i_start > 0.0f && (!(cfg->a_start > 0.0f) || !(cfg->w_handover > 0.0f))) return FS_ERR_PARAM;
    fs_drive_reset(drv);
    return FS_OK;
}

void fs_drive_reset(fs_drive *drv)
{
    fs_current_ctrl_reset(&drv->cc);
    fs_pll_reset(&drv->pll, 0.0f, 0.0f);
    if (drv->cfg.mode == FS_MODE_SPEED) fs_speed_ctrl_reset(&drv->sc);
    if (drv->cfg.angle_source == FS_ANGLE_SMO) fs_smo_reset(&drv->smo, 0.0f, 0.0f);
    if (drive_weakens(&drv->cfg)) fs_fw_reset(&drv->fw);
    drv->phase = drive_starts(&drv->cfg) ? FS_PHASE_START : FS_PHASE_RUN;
    drv->theta_if = drv->w_if = 0.0f;
    drv->theta_ol = 0.0f;
    drv->pll_started = false;
    drv->u_hist[0].alpha = drv->u_hist[0].beta = 0.0f;
    drv->u_hist[1] = drv->u_hist[0];
}

/* Angle and speed from the configured source. */
static void drive_angle(fs_drive *drv, const fs_drive_in *in, fs_ab i_ab, float *theta, float *w)
{
    if (drv->cfg.angle_source == FS_ANGLE_SMO) {
        /* the voltage that acted during the period that ended now */
        fs_ab u = drv->cfg.delay > 0.5f ? drv->u_hist[1] : drv->u_hist[0];
        fs_smo_step(&drv->smo, i_ab, u);
        if (in->sensorless) {
            bool start = drv->phase == FS_PHASE_START;
            *theta = start ? drv->theta_if : drv->smo.theta;
            *w = start ? drv->w_if : drv->smo.w;
            return;
        }
    }
    if (drv->cfg.angle_source == FS_ANGLE_EXTERNAL) {
        *theta = in->theta_e_ext;
        *w = in->w_e_ext;
        return;
    }
    float theta_enc = fs_wrap_pi((float)drv->cfg.pole_pairs * in->theta_m_enc);
    if (!drv->pll_started) {
        fs_pll_reset(&drv->pll, theta_enc, 0.0f);
        drv->pll_started = true;
    }
    /* The PLL's angle is its prediction for this sample. */
    fs_pll_step(&drv->pll, fs_wrap_pi(theta_enc - drv->pll.theta));
    *theta = theta_enc;
    *w = drv->pll.w;
}

/* I/f start: the frame accelerates towards the reference, or up to the
 * hand-over speed, with i_start on its d axis; the rotor's d axis lags the
 * current by the load angle at which the torque carries the load and the
 * acceleration (self-synchronising, and at standstill the current aligns the
 * rotor without torque). Once past the hand-over speed with the observer valid and turning
 * the same way, the loops take the observer, and the speed controller's
 * integral is preset to the torque the current makes in the observer's
 * frame, so that the hand-over does not bump the torque. */
static fs_dq drive_start_step(fs_drive *drv, const fs_drive_in *in, fs_ab i_ab)
{
    const fs_drive_config *c = &drv->cfg;
    float w_target = fs_clampf((float)c->pole_pairs * in->w_m_ref, -c->w_handover, c->w_handover);
    float dw = c->a_start * c->Ts;
    drv->w_if += fs_clampf(w_target - drv->w_if, -dw, dw);
    drv->theta_if = fs_wrap_pi(drv->theta_if + c->Ts * drv->w_if);
    fs_dq i_ref = {c->i_start, 0.0f};
    bool fast = fabsf(drv->w_if) >= c->w_handover * 0.999f;
    if (fast && drv->smo.valid && drv->smo.w * drv->w_if > 0.0f) {
        fs_dq i_o = fs_park(i_ab, cosf(drv->smo.theta), sinf(drv->smo.theta));
        float T = 1.5f * (float)c->pole_pairs * (c->psi_f + (c->L_d - c->L_q) * i_o.d) * i_o.q;
        fs_speed_ctrl_preset(&drv->sc, drv->smo.w / (float)c->pole_pairs, T);
        drv->phase = FS_PHASE_RUN;
    }
    return i_ref;
}

/* Dead-time compensation: the average pole-voltage loss is
 * sign(i) t_dead / T_pwm u_dc, added back on the duty. */
static void dead_time_comp(const fs_drive_config *c, const float i_abc[3], float duty[3])
{
    if (c->t_dead_comp <= 0.0f) return;
    float dd = c->t_dead_comp / c->T_pwm;
    for (int k = 0; k < 3; ++k) {
        float s = (c->i_dead_band > 0.0f) ? fs_clampf(i_abc[k] / c->i_dead_band, -1.0f, 1.0f)
                                          : fs_signf(i_abc[k]);
        duty[k] = fs_clampf(duty[k] + s * dd, 0.0f, 1.0f);
    }
}

void fs_drive_step(fs_drive *drv, const fs_drive_in *in, fs_drive_out *out)
{
    const fs_drive_config *c = &drv->cfg;
    fs_ab i_ab = fs_clarke(in->i_abc[0], in->i_abc[1], in->i_abc[2]);
    float theta, w_e;
    drive_angle(drv, in, i_ab, &theta, &w_e);

    fs_dq u_ref = {0.0f, 0.0f};
    fs_dq i_ref = {0.0f, 0.0f};
    float T_ref = 0.0f;
    bool closed_loop = (c->mode == FS_MODE_CURRENT || c->mode == FS_MODE_SPEED);

    if (c->mode == FS_MODE_VOLTAGE_DQ || c->mode == FS_MODE_VF) {
        theta = drv->theta_ol;
        w_e = in->w_e_ref;
        drv->theta_ol = fs_wrap_pi(drv->theta_ol + c->Ts * in->w_e_ref);
        if (c->mode == FS_MODE_VOLTAGE_DQ) {
            u_ref.d = in->u_d_ref;
            u_ref.q = in->u_q_ref;
        } else {
            u_ref.q = fs_signf(in->w_e_ref) * (c->vf_boost + c->vf_gain * fabsf(in->w_e_ref));
        }
    }
    float cos_t = cosf(theta), sin_t = sinf(theta);
    fs_dq i_dq = fs_park(i_ab, cos_t, sin_t);
    bool starting = in->sensorless && drv->phase == FS_PHASE_START;

    if (closed_loop) {
        if (c->mode == FS_MODE_SPEED && starting) {
            i_ref = drive_start_step(drv, in, i_ab);
        } else if (c->mode == FS_MODE_SPEED) {
            T_ref = fs_speed_ctrl_step(&drv->sc, in->w_m_ref, w_e / (float)c->pole_pairs);
            i_ref = fs_mtpa_step(&drv->mtpa, T_ref);
            if (drive_weakens(c)) {
                /* zou2021 eq. (30): i_d* = i_d0* + the filtered correction,
                 * i_q* kept, then held inside the current limit circle */
                i_ref.d = fs_clampf(i_ref.d + drv->fw.i_d, -c->i_max, c->i_max);
                float iq_max = sqrtf(c->i_max * c->i_max - i_ref.d * i_ref.d);
                i_ref.q = fs_clampf(i_ref.q, -iq_max, iq_max);
            }
        } else {
            i_ref.d = in->i_d_ref;
            i_ref.q = in->i_q_ref;
        }
        u_ref = fs_current_ctrl_step(&drv->cc, i_ref, i_dq, w_e);
    }

    /* The voltage acts from the next update instant for one period: rotate it
     * by the angle the rotor turns until the middle of that period. */
    float theta_u = theta + w_e * c->Ts * (c->delay + 0.5f);
    float cos_u = cosf(theta_u), sin_u = sinf(theta_u);
    fs_ab u_ab_ref = fs_inv_park(u_ref, cos_u, sin_u);
    fs_ab u_ab;
    if (c->mode == FS_MODE_OFF) {
        out->duty[0] = out->duty[1] = out->duty[2] = 0.5f;
        out->over_modulation = false;
        u_ab.alpha = u_ab.beta = 0.0f;
    } else {
        out->over_modulation = fs_svpwm(u_ab_ref, in->u_dc, out->duty, &u_ab);
        dead_time_comp(c, in->i_abc, out->duty);
    }
    drv->u_hist[1] = drv->u_hist[0];
    drv->u_hist[0] = u_ab;
    fs_dq u_real = fs_park(u_ab, cos_u, sin_u);
    if (closed_loop) fs_current_ctrl_update(&drv->cc, u_real);
    if (drive_weakens(c) && !starting)
        fs_fw_step(&drv->fw, u_ref.q - u_real.q, w_e);   /* eq. (26): dv_q */

    out->theta_e = theta;
    out->w_e = w_e;
    out->i_d = i_dq.d;
    out->i_q = i_dq.q;
    out->i_d_ref = i_ref.d;
    out->i_q_ref = i_ref.q;
    out->T_ref = T_ref;
    out->u_d = u_real.d;
    out->u_q = u_real.q;
    bool smo = c->angle_source == FS_ANGLE_SMO;
    out->theta_est = smo ? drv->smo.theta : theta;
    out->w_est = smo ? drv->smo.w : w_e;
    out->est_valid = smo ? drv->smo.valid : true;
    out->phase = drv->phase;
    out->i_d_fw = drive_weakens(c) ? drv->fw.i_d : 0.0f;
}
