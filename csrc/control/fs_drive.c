#include "fs_blend_angle.h"
#include "fs_drive.h"
#include "fs_drive_ident.h"
#include "fs_drive_protect.h"
#include "fs_drive_start.h"
#include "fs_math.h"

#include <stddef.h>

/* The float fields the drive reads, with the range each must be in whatever
 * the mode (F finite, N >= 0 and finite, P > 0 and finite; the rest is
 * checked where it is used) and the status that refuses it. */
enum { F = 0, N = 1, P = 2 };
#define DRIVE_FIELDS(X) \
    X(Ts, P, FS_ERR_TS) X(T_pwm, P, FS_ERR_TS) X(delay, F, FS_ERR_PARAM) \
    X(R_s, N, FS_ERR_RS) X(L_d, P, FS_ERR_LD) X(L_q, P, FS_ERR_LQ) X(psi_f, N, FS_ERR_PSI_F) \
    X(L_d_hf, N, FS_ERR_LD) X(L_q_hf, N, FS_ERR_LQ) \
    X(J, F, FS_ERR_J) X(B, N, FS_ERR_PARAM) X(i_max, P, FS_ERR_I_MAX) X(T_max, F, FS_ERR_LIMIT) \
    X(bw_current, F, FS_ERR_BANDWIDTH) X(bw_speed, F, FS_ERR_BANDWIDTH) X(bw_pll, F, FS_ERR_BANDWIDTH) \
    X(t_dead_comp, N, FS_ERR_PARAM) X(i_dead_band, N, FS_ERR_PARAM) X(vf_gain, F, FS_ERR_PARAM) \
    X(vf_boost, F, FS_ERR_PARAM) X(smo.w_e_max, F, FS_ERR_LIMIT) X(smo.i_max, F, FS_ERR_LIMIT) \
    X(smo.k, F, FS_ERR_SMO_GAIN) X(smo.margin, F, FS_ERR_LIMIT) X(smo.delta, F, FS_ERR_PARAM) \
    X(smo.w_c_min, F, FS_ERR_BANDWIDTH) X(smo.bw_pll, F, FS_ERR_BANDWIDTH) X(smo.w_valid, F, FS_ERR_PARAM) \
    X(fw_w_e_max, N, FS_ERR_LIMIT) X(fw_gain, N, FS_ERR_PARAM) X(fw_cutoff, N, FS_ERR_BANDWIDTH) \
    X(lock_time, N, FS_ERR_LIMIT) X(t_recover, F, FS_ERR_PARAM) X(w_over, N, FS_ERR_LIMIT) X(i_start, N, FS_ERR_I_MAX) \
    X(a_start, F, FS_ERR_PARAM) X(w_handover, F, FS_ERR_PARAM) X(hfi.u_h, F, FS_ERR_PARAM) \
    X(hfi.w_h, F, FS_ERR_BANDWIDTH) X(hfi.w_b_p, F, FS_ERR_BANDWIDTH) X(hfi.w_b_n, F, FS_ERR_BANDWIDTH) \
    X(hfi.obs.bandwidth, F, FS_ERR_BANDWIDTH) X(blend.w_lower, F, FS_ERR_LIMIT) X(blend.w_upper, F, FS_ERR_LIMIT) \
    X(blend.obs.bandwidth, F, FS_ERR_BANDWIDTH) X(w_inject_max, N, FS_ERR_LIMIT) \
    X(polarity.i_pulse, F, FS_ERR_I_MAX) X(polarity.t_lock, F, FS_ERR_PARAM) X(polarity.t_pulse, F, FS_ERR_PARAM) \
    X(polarity.i_pulse_max, N, FS_ERR_I_MAX) X(polarity.d_min, N, FS_ERR_PARAM) X(polarity.w_filter, N, FS_ERR_BANDWIDTH) \
    X(polarity.w_max, N, FS_ERR_PARAM) \
    X(swvi.u_h, F, FS_ERR_PARAM) X(swvi.bandwidth, F, FS_ERR_BANDWIDTH) X(swvi.w_max, F, FS_ERR_LIMIT) \
    X(k_p_d, N, FS_ERR_PARAM) X(k_i_d, N, FS_ERR_PARAM) X(k_p_q, N, FS_ERR_PARAM) X(k_i_q, N, FS_ERR_PARAM) \
    X(k_p_w, N, FS_ERR_PARAM) X(k_i_w, N, FS_ERR_PARAM) X(imc_w_grid, N, FS_ERR_PARAM) \
    X(imc_i_lim, F, FS_ERR_I_MAX) X(imc_V_im, F, FS_ERR_LIMIT) X(T_slew, N, FS_ERR_LIMIT)
/* two bytes a field: its offset in floats, its kind and status; the names
 * in one string, in the same order, each ended by a NUL */
#define FIELD_ENTRY(f, kind, status) {(uint8_t)((uint32_t)offsetof(fs_drive_config, f) / (uint32_t)sizeof(float)), (uint8_t)(((uint32_t)(kind) << 6u) | (uint32_t)(status))},
#define FIELD_NAME(f, kind, status) #f "\0"
static const uint8_t drive_fields[][2] = {DRIVE_FIELDS(FIELD_ENTRY)};
static const char drive_field_names[] = DRIVE_FIELDS(FIELD_NAME);
/* every field the table names lies before the flux map (checked by
 * fs_fluxmap_init), within 256 floats of the start */
typedef char drive_fields_fit[(offsetof(fs_drive_config, map) <= 256 * sizeof(float) && FS_ERR__COUNT < 64) ? 1 : -1];

/* The first field of the table out of its range, its status and its name. */
static FS_COLD fs_status drive_check_fields(const fs_drive_config *cfg, const char **name)
{
    const char *s = drive_field_names;
    for (size_t k = 0; k < sizeof drive_fields / sizeof drive_fields[0]; ++k) {
        const float x = ((const float *)(const void *)cfg)[drive_fields[k][0]];
        const int kind = drive_fields[k][1] >> 6;
        if (!fs_fin(x) || (kind == N && !(x >= 0.0f)) || (kind == P && !(x > 0.0f))) {
            *name = s;
            const uint32_t status = (uint32_t)drive_fields[k][1] & 63u;   /* the low six bits */
            return (fs_status)status;
        }
        while (*s++ != '\0') {}
    }
    return FS_OK;
}

/* The injection estimators: HFI (and blend). */
static FS_COLD fs_status drive_init_injection(fs_drive *drv, const fs_drive_config *cfg)
{
    fs_motion_obs_config mo = {cfg->Ts, cfg->J, cfg->B, cfg->pole_pairs, 0.0f};
    fs_hfi_config hc = cfg->hfi;
    hc.Ts = cfg->Ts;
    hc.delay = cfg->delay;
    hc.R_s = cfg->R_s;
    hc.L_d = cfg->L_d_hf > 0.0f ? cfg->L_d_hf : cfg->L_d;   /* fs_drive.h */
    hc.L_q = cfg->L_q_hf > 0.0f ? cfg->L_q_hf : cfg->L_q;
    mo.bandwidth = hc.obs.bandwidth;
    hc.obs = mo;
    if (!fs_pos(cfg->J)) { REFUSE("J", FS_ERR_J); }
    SUB("hfi", fs_hfi_init(&drv->hfi, &hc));
    /* the carrier current's peak, I_p + I_n = u_h / (w_h min(L_d, L_q)) */
    drv->i_hf = hc.u_h / (drv->hfi.cfg.w_h * fs_minf(hc.L_d, hc.L_q));
    if (!(drv->i_hf < 0.5f * cfg->i_max)) { REFUSE("hfi.u_h", FS_ERR_ABOVE_I_MAX); }
    if (cfg->angle_source == (int)FS_ANGLE_BLEND) {
        fs_blend_config bc = cfg->blend;
        mo.bandwidth = bc.obs.bandwidth > 0.0f ? bc.obs.bandwidth : drv->hfi.w_o_blend;   /* fs_hfi.h */
        bc.obs = mo;
        SUB("blend", fs_blend_init(&drv->blend, &bc));
        if (cfg->w_inject_max > 0.0f && !(0.9f * cfg->w_inject_max >= bc.w_upper)) { REFUSE("w_inject_max", FS_ERR_LIMIT); }
    }
    return FS_OK;
}

FS_COLD fs_status fs_drive_init(fs_drive *drv, const fs_drive_config *cfg)
{
    if (!drv) { return FS_ERR_NULL; }
    drv->fail = NULL;
    if (!cfg) { REFUSE("config", FS_ERR_NULL); }
    if (cfg->config_size != 0u && cfg->config_size != (unsigned int)sizeof(fs_drive_config)) { REFUSE("config_size", FS_ERR_PARAM); }
    if (cfg->mode == (int)FS_MODE_IDENTIFY) {   /* knows no machine yet */
        if (!FS_WITH_IDENT) { REFUSE("mode", FS_ERR_MODE); }
        return fs_drive_ident_init(drv, cfg);
    }
    fs_status st = drive_check_fields(cfg, &drv->fail);
    if (st != FS_OK) { return st; }
    if (cfg->phases != 3 && cfg->phases != 5) { REFUSE("phases", FS_ERR_PARAM); }
    /* what this build leaves out (fs_drive.h, FS_WITH_*) */
    if (!FS_WITH_FIVE_PHASE && cfg->phases == 5) { REFUSE("phases", FS_ERR_MODE); }
    if (!FS_WITH_SWVI && cfg->angle_source == (int)FS_ANGLE_SWVI) { REFUSE("angle_source", FS_ERR_MODE); }
    if (!FS_WITH_IMC && cfg->converter == (int)FS_CONV_IMC) { REFUSE("converter", FS_ERR_MODE); }
    if (!FS_WITH_ADAPT && cfg->adapt.T_f > 0.0f) { REFUSE("adapt", FS_ERR_MODE); }
    if (!FS_WITH_DTCOMP && cfg->dt_predict) { REFUSE("dt_predict", FS_ERR_MODE); }
    if (cfg->mode < (int)FS_MODE_OFF || cfg->mode > (int)FS_MODE_SPEED) { REFUSE("mode", FS_ERR_MODE); }
    if (cfg->angle_source < (int)FS_ANGLE_ENCODER || cfg->angle_source > (int)FS_ANGLE_SWVI) { REFUSE("angle_source", FS_ERR_MODE); }
    if (!(cfg->T_pwm >= cfg->Ts)) { REFUSE("T_pwm", FS_ERR_TS); }
    if (!(cfg->delay >= 0.0f && cfg->delay <= 2.0f)) { REFUSE("delay", FS_ERR_PARAM); }
    if (cfg->pole_pairs < 1) { REFUSE("pole_pairs", FS_ERR_POLE_PAIRS); }
    if (!(cfg->t_dead_comp < 0.5f * cfg->T_pwm)) { REFUSE("t_dead_comp", FS_ERR_PARAM); }
    drv->cfg = *cfg;
    drv->has_map = cfg->map.di_d != 0.0f;
    if (!FS_WITH_FLUXMAP && drv->has_map) { REFUSE("map", FS_ERR_MODE); }
    if (drive_fw_plans(drv)) { SUB("map", fs_fluxmap_init(&drv->map, &drv->cfg.map)); }
    drv->k_T = drive_torque_k(cfg);
    drv->dd_dead = cfg->t_dead_comp / cfg->T_pwm;
    const float Tl = drive_loop_Ts(cfg);

    fs_current_ctrl_config ccc = {Tl, cfg->R_s, cfg->L_d, cfg->L_q, cfg->psi_f, cfg->bw_current,
                                  cfg->delay > 0.5f, cfg->k_p_d, cfg->k_i_d, cfg->k_p_q, cfg->k_i_q};
    if (cfg->cc_internal_model && ccc.k_p_d == 0.0f && ccc.k_i_d == 0.0f && ccc.k_p_q == 0.0f && ccc.k_i_q == 0.0f) {
        fs_current_ctrl_internal_model(&ccc);   /* fs_drive.h */
    }
    st = fs_current_ctrl_init(&drv->cc, &ccc);
    if (st != FS_OK) { REFUSE(st == FS_ERR_BANDWIDTH ? "bw_current" : "k_p_d, k_i_d, k_p_q, k_i_q", st); }

    fs_pll_config pc = {cfg->Ts, cfg->bw_pll, 0.0f};
    SUB("bw_pll", fs_pll_init(&drv->pll, &pc));

    if (drive_has_smo(cfg)) {
        fs_smo_config oc = cfg->smo;
        oc.Ts = cfg->Ts;
        oc.R_s = cfg->R_s;
        oc.L_d = cfg->L_d;
        oc.L_q = cfg->L_q;
        oc.psi_f = cfg->psi_f;
        oc.J = cfg->J;            /* the tracking form's motion observer and torque */
        oc.B = cfg->B;
        oc.pole_pairs = cfg->pole_pairs;
        oc.phases = cfg->phases;
        oc.dir_external = cfg->angle_source == (int)FS_ANGLE_BLEND;
        SUB("smo", fs_smo_init(&drv->smo, &oc));
    }
    if (cfg->phases == 5 && cfg->bw_xy > 0.0f) {
        fs_xyctrl_config xc = {cfg->Ts, cfg->delay, cfg->R_s, cfg->L_d3, cfg->L_q3, cfg->psi_f3, cfg->bw_xy,
                               0.1f};   /* 10 % of u_dc: a few times what psi_f3 and the dead time ask */
        SUB("bw_xy", fs_xyctrl_init(&drv->xy, &xc));
    }
    if (FS_WITH_DTCOMP && cfg->dt_predict && cfg->t_dead_comp > 0.0f) {
        fs_dtcomp_config dc = {cfg->phases, cfg->T_pwm, cfg->Ts, cfg->delay, cfg->t_dead_comp, cfg->i_dead_band,
                               cfg->L_d, cfg->L_q};
        SUB("dt_predict", fs_dtcomp_init(&drv->dtc, &dc));
    }
    if (FS_WITH_ADAPT && cfg->adapt.T_f > 0.0f) {
        fs_param_adapt_config ac = cfg->adapt;
        ac.Ts = cfg->Ts;
        ac.R_s = cfg->R_s;
        ac.L_d = cfg->L_d;
        ac.psi_f = cfg->psi_f;
        ac.i_max = cfg->i_max;
        if (!(ac.w_e_max > 0.0f)) { ac.w_e_max = cfg->smo.w_e_max; }
        SUB("adapt", fs_param_adapt_init(&drv->adapt, &ac));
    }
    if (cfg->mode == (int)FS_MODE_SPEED) {
        fs_speed_ctrl_config scc = {Tl, cfg->J, cfg->B, cfg->bw_speed, cfg->T_max, cfg->k_p_w, cfg->k_i_w};
        st = fs_speed_ctrl_init(&drv->sc, &scc);
        if (st != FS_OK) {
            REFUSE(st == FS_ERR_J ? "J" : st == FS_ERR_BANDWIDTH ? "bw_speed" : st == FS_ERR_LIMIT ? "T_max" : "k_p_w, k_i_w", st);
        }
        fs_mtpa_config mc = {cfg->L_d, cfg->L_q, cfg->psi_f, cfg->pole_pairs, cfg->i_max, cfg->phases,
                             drive_map(drv) ? &drv->map : NULL};
        st = fs_mtpa_init(&drv->mtpa, &mc);
        if (st != FS_OK) { REFUSE(st == FS_ERR_LQ ? "L_q" : drive_map(drv) ? "mtpa (map, i_max)" : "mtpa (psi_f, L_d, L_q, i_max)", st); }
        if (drive_weakens(cfg) && drive_fw_plans(drv)) {
            if (drive_five(cfg) || drive_imc(cfg)) { REFUSE("map", FS_ERR_MODE); }   /* the voltage limit is the VSI's, three phases */
            if (cfg->fw_hold != 0) { REFUSE("fw_hold", FS_ERR_MODE); }   /* fs_fw.h's excess feeds no loop here */
            fs_fwmap_config wc = {&drv->map, cfg->i_max, drv->k_T, cfg->Ts, cfg->bw_current};
            SUB("map (flux weakening)", fs_fwmap_init(&drv->fwm, &wc, &drv->mtpa));
        }
        if (drive_weakens(cfg)) {
            if (!(cfg->fw_gain >= 0.0f)) { REFUSE("fw_gain", FS_ERR_PARAM); }
            fs_fw_config fc = {cfg->Ts, cfg->L_d, cfg->fw_w_e_max, cfg->fw_gain, cfg->fw_cutoff, cfg->i_max};
            fs_fw_design(&fc, cfg->bw_current, cfg->fw_hold != 0);   /* gain or cutoff 0: fs_drive.h */
            st = fs_fw_init(&drv->fw, &fc);
            if (st != FS_OK) { REFUSE(st == FS_ERR_BANDWIDTH ? "fw_cutoff" : "fw_w_e_max", st); }
        }
    }
    if (cfg->lock_time > 0.0f) {
        fs_lock_config lc = {Tl, cfg->lock_time};
        SUB("lock_time", fs_lock_init(&drv->lock, &lc));
        drv->lock_a = fs_exp_pole(-4.0f * Tl / cfg->lock_time);
        /* the rating: T_max, or in current mode the torque of i_max on q */
        const float T_lim = fs_maxf(cfg->T_max, fabsf(drive_torque(cfg, (fs_dq){0.0f, cfg->i_max})));
        const float delay_steps = cfg->delay + 0.5f;   /* rounded by the truncation to int */
        fs_monitor_config mc = {Tl, (int)delay_steps, cfg->R_s, cfg->L_d, cfg->L_q, cfg->psi_f,
                                cfg->pole_pairs, fs_maxf(cfg->J, 0.0f), cfg->B, T_lim, cfg->i_max,
                                cfg->t_dead_comp / cfg->T_pwm, 0.25f * cfg->lock_time, cfg->lock_time,
                                drive_injects(cfg) ? cfg->hfi.w_h : 0.0f};
        SUB("lock_time", fs_monitor_init(&drv->mon, &mc));
    }
    if (cfg->lock_recover != 0 && cfg->lock_recover != 1) { REFUSE("lock_recover", FS_ERR_PARAM); }
    if (cfg->lock_recover != 0) {
        if (!(cfg->lock_time > 0.0f)) { REFUSE("lock_time", FS_ERR_PARAM); }
        if (!fs_pos(cfg->t_recover)) { REFUSE("t_recover", FS_ERR_PARAM); }
        if (cfg->lock_retries < 0) { REFUSE("lock_retries", FS_ERR_PARAM); }
        if (drive_square(cfg)) { REFUSE("lock_recover", FS_ERR_MODE); }   /* no restart sequence for the square wave */
    }
    if (drive_injects(cfg)) {
        st = drive_init_injection(drv, cfg);
        if (st != FS_OK) { return st; }
    }
    if (drive_square(cfg)) {
        if (cfg->mode != (int)FS_MODE_OFF && cfg->mode != (int)FS_MODE_CURRENT && cfg->mode != (int)FS_MODE_SPEED) { REFUSE("mode", FS_ERR_MODE); }
        if (cfg->delay != 0.0f && cfg->delay != 1.0f) { REFUSE("delay", FS_ERR_PARAM); }
        fs_swvi_config wc = cfg->swvi;
        wc.Ts = cfg->Ts;
        wc.delay = (int)cfg->delay;
        wc.L_d = cfg->L_d;
        wc.L_q = cfg->L_q;
        SUB("swvi", fs_swvi_init(&drv->sw, &wc));
    }
    if (cfg->converter != (int)FS_CONV_VSI && cfg->converter != (int)FS_CONV_IMC) { REFUSE("converter", FS_ERR_MODE); }
    if (drive_imc(cfg)) {
        if (cfg->phases != 3 || drive_square(cfg)) { REFUSE("converter", FS_ERR_MODE); }
        if (cfg->imc_region < (int)FS_IMC_LINEAR || cfg->imc_region > (int)FS_IMC_OM2) { REFUSE("imc_region", FS_ERR_MODE); }
        if (drive_imc_depth(cfg)) {
            if (!(cfg->imc_i_lim > 0.0f)) { REFUSE("imc_i_lim", FS_ERR_I_MAX); }
            if (cfg->imc_i_lim > cfg->i_max) { REFUSE("imc_i_lim", FS_ERR_ABOVE_I_MAX); }
            fs_imc_depth_config dc;
            st = fs_imc_depth_design(&dc, cfg->Ts, cfg->imc_i_lim, cfg->imc_V_im, cfg->fw_w_e_max,
                                     cfg->L_d, cfg->bw_speed);
            if (st != FS_OK) { REFUSE(st == FS_ERR_LIMIT ? "imc_V_im" : "imc_depth", st); }
            SUB("imc_depth", fs_imc_depth_init(&drv->depth, &dc));
        }
    }
    st = fs_drive_start_init(drv, cfg);
    if (st != FS_OK) { return st; }
    fs_drive_reset(drv);
    return FS_OK;
}

FS_COLD void fs_drive_reset(fs_drive *drv)
{
    if (FS_WITH_IDENT && drv->cfg.mode == (int)FS_MODE_IDENTIFY) {
        fs_ident_reset(&drv->ident);
        return;
    }
    fs_current_ctrl_reset(&drv->cc);
    fs_pll_reset(&drv->pll, 0.0f, 0.0f);
    if (drv->cfg.mode == (int)FS_MODE_SPEED) { fs_speed_ctrl_reset(&drv->sc); }
    if (drive_has_smo(&drv->cfg)) { fs_smo_reset(&drv->smo, 0.0f, 0.0f); }
    if (drive_weakens(&drv->cfg)) { fs_fw_reset(&drv->fw); }
    if (drive_weakens(&drv->cfg) && drive_fw_plans(drv)) { fs_fwmap_reset(&drv->fwm); }
    if (drive_injects(&drv->cfg)) {
        fs_hfi_reset(&drv->hfi, 0.0f, 0.0f);
        fs_hfi_fade_in(&drv->hfi);   /* its error read once the filters have settled on the whole carrier */
        drv->blend.g_w = 0.0f;   /* the injection's weight whole without a blend: the torque's slew reads it */
        if (drv->cfg.angle_source == (int)FS_ANGLE_BLEND) { fs_blend_reset(&drv->blend, 0.0f, 0.0f); }
    }
    fs_drive_start_reset(drv);
    if (drive_square(&drv->cfg)) { fs_swvi_reset(&drv->sw, 0.0f, 0.0f); }
    if (drive_imc_depth(&drv->cfg)) { fs_imc_depth_reset(&drv->depth); }
    if (drv->cfg.lock_time > 0.0f) {
        fs_lock_reset(&drv->lock);
        fs_monitor_reset(&drv->mon);
    }
    drv->lock_ri = drv->lock_es = drv->lock_eh = drv->lock_ex = 0.0f;
    drv->t_quiet = 0.0f;
    drv->stage = FS_STAGE_OPEN;
    drv->recoveries = 0;
    drv->fault = FS_FAULT_NONE;
    drv->w_over = drv->cfg.w_over > 0.0f ? drv->cfg.w_over : FS_DRIVE_NO_LIMIT;
    drv->t_left = 0.0f;
    drv->alpha = 0.0f;
    drv->u_ff_hold.alpha = drv->u_ff_hold.beta = 0.0f;
    drv->u_ff_next = drv->u_ff_hold;
    drv->held = (fs_drive_out){0};
    drv->est_started = false;
    drv->injecting = drv->inject_on = drive_injects(&drv->cfg);
    drv->T_ff = 0.0f;
    drv->T_slew = 0.0f;
    drv->fw_map_on = false;
    drv->follows = false;
    drv->smo_transient = false;   /* until the map's first step (drive_map_step) */
    drv->smo_k_speed = 0.0f;
    drv->phase = drive_starts(&drv->cfg) ? FS_PHASE_START : FS_PHASE_RUN;
    drv->theta_ol = 0.0f;
    drv->pll_started = false;
    drv->pll_seeded = false;
    drv->u_hist[0].alpha = drv->u_hist[0].beta = 0.0f;
    drv->u_hist[1] = drv->u_hist[0];
}

/* The voltage the back-EMF observer takes for the period that ended now:
 * the realised one, with the map less the transient its incremental
 * inductances put across the machine, (L_inc - L_d) di_dq/dt (fs_smo.h,
 * saturation's transient). Without FS_WITH_FLUXMAP drive_map is a constant
 * false: the realised voltage alone, no code (B-PIL's step). */
static inline fs_ab drive_smo_u(const fs_drive *drv, fs_ab i)
{
    fs_ab u = drive_u_past(drv);
    if (drive_map(drv) && drv->smo_transient) {
        const fs_ab v = fs_smo_transient(&drv->smo, i, &drv->smo_at);
        u.alpha -= v.alpha;
        u.beta -= v.beta;
    }
    return u;
}

/* Whether the injection may stop above w_inject_max (drive_injection_step):
 * the blend's trust whole, or the planned flux weakening on and the SMO
 * converged. A function so that the step evaluates it only there. */
static inline bool drive_handed_over(const fs_drive *drv)
{
    return (drv->blend.trust >= 1.0f) || (drv->fw_map_on && drv->smo.converged);
}

/* HFI (while injecting), the SMO on the fundamental, the blend; the
 * fundamental current is returned for the loops. */
static fs_ab drive_injection_step(fs_drive *drv, fs_ab i_ab)
{
    const fs_drive_config *c = &drv->cfg;
    const float T_ff = drv->T_ff;
    fs_ab i_f = i_ab;
    if (drv->injecting) {
        (void)fs_hfi_step(&drv->hfi, i_ab, T_ff);
        i_f = drv->hfi.i_f;
    }
    if (c->angle_source == (int)FS_ANGLE_BLEND) {
        /* the direction from the blended speed once it is clear of the
         * injection estimate's wander at standstill; while recovering from
         * a lost blend, from the observer's own speed past w_valid */
        const bool own = drv->phase == (int)FS_PHASE_RECOVER;
        const float w_dir = own ? drv->smo.w : drv->blend.w_hat;
        const float w_min = own ? drv->smo.cfg.w_valid : 0.5f * drv->blend.cfg.w_lower;
        if (fabsf(w_dir) > w_min) { fs_smo_set_dir(&drv->smo, w_dir); }
        /* below its validity the observer starts from the blended estimate
         * (fs_smo_follow; the tracking form only) */
        if (!own) { fs_smo_follow(&drv->smo, drv->blend.theta_hat, drv->blend.w_hat, drv->blend.obs.T_d_hat); }
        /* While injecting, an observer beyond the speed it is designed for
         * (smo.w_e_max) has no estimate: started afresh from the blend's. At
         * standstill under the carrier a saturating machine's current holds
         * the carrier's harmonics, whose rectified EMF took the Baldor
         * PM-SyRM's tracker to -80,000 rpm, its current estimate against its
         * bound; it never came back, the blend never trusted it, and the
         * injection ran to 1.5 x base speed, its carrier's voltage taken off
         * the fundamental's (184 of 311 V), where B-REAL's load step lost
         * the speed */
        if (!own && drv->injecting && !(fabsf(drv->smo.w) <= c->smo.w_e_max)) {
            fs_smo_reset(&drv->smo, drv->blend.theta_hat, drv->blend.w_hat);
        }
        (void)fs_smo_step(&drv->smo, i_f, drive_smo_u(drv, i_f));
        /* the speed the EMF's magnitude gives, where the map says the EMF's angle sees little of the
         * error (fs_smo_speed): on the machine's own current (not the filters' fundamental, whose EMF
         * read 1,344 rpm for a period on the Prius at 294), and not in the planned flux weakening, whose
         * active flux is the d current's small difference, so that the map's error in it is the speed's */
        if (drive_map(drv) && !drv->inject_on && !drv->fw_map_on) { fs_smo_speed(&drv->smo, drv->smo_k_speed); }
        /* while the injection's estimate settles it coasts on its model: where the SMO has converged, it
         * follows the SMO instead, so that its weight in the blend and its first corrections start from the
         * better estimate (the example lock-loss.toml, caught at -590 rpm by its flying restart and
         * accelerating through the band at 6,000 rpm/s: the coasting estimate ran 34 el.deg off and the
         * drive's 38, while the SMO stayed within 2) */
        if ((drv->hfi.k_settle > 0) && drv->smo.converged) {
            /* at the filters' bandwidth, not taken whole each step: the SMO's angle noise would turn the
             * filters' frames and with them the fundamental into the carrier's band (fs_hfi_follow) */
            fs_hfi_follow(&drv->hfi, drv->smo.theta, drv->smo.w);
            fs_hfi_set_load(&drv->hfi, drv->smo.mo.T_d_hat);
        }
        (void)fs_blend_step_gated(&drv->blend, drv->smo.theta, drv->hfi.theta, T_ff,   /* Fig. 6 */
                                  drv->smo.converged || !c->blend.gate, drv->injecting && drv->hfi.gain >= 1.0f);
        /* With a flux map, above the band the blend is the back-EMF observer's own tracker (its torque
         * from the map, at up to observer.bw_pll): in deep flux weakening the torque feed-forward's
         * sensitivity to the angle, d T / d theta ~ (phases / 2) p psi_a (-i_d), pulls an estimate that
         * lags further behind (a negative stiffness (p / J) dT/dtheta: 19,000 s^-2 on the Prius MG2 at
         * -73 A, psi_a 0.38 Wb, J 0.035 kg m^2), which the blend's slower filter (w_o_blend, 63 rad/s
         * there) does not overcome: it lost the rotor accelerating through 2,700 rpm. */
        /* Once following, it follows while the tracker is valid: above the band it is the only source, and
         * `converged` drops on one sample's settled-error test; on SyR-e's THOR held at 1,037 rpm by a load
         * machine, the torque's rise to T_max took the tracker's innovation past 5 el.deg for a moment
         * and the blend, left on its own model at its slower bandwidth, ran 40 el.deg off in 13 ms while
         * the tracker stayed within 11 */
        const bool trusted = drv->smo.converged || (drv->follows && drv->smo.valid);
        drv->follows = drive_map(drv) && drv->blend.g_w >= 1.0f && trusted && c->smo.form == (int)FS_SMO_FORM_TRACKING;
        if (drv->follows) {
            fs_blend_follow(&drv->blend, drv->smo.theta, drv->smo.w, drv->smo.mo.T_d_hat);
        }
        /* Above w_inject_max the injection stops (g_w = 1 there: the HFI
         * angle is not read); below 0.9 w_inject_max it resumes from the
         * blended estimate. */
        const float aw = fabsf(drv->blend.w_hat);
        /* ... and, with the blend's gate, only once the SMO has converged
         * (fs_blend.h: a load release can carry the rotor past it before):
         * at full trust, or where the planned flux weakening is on (its
         * voltage is short and the carrier's amplitude comes off it) once
         * the SMO has converged at all. Waiting there for the trust (4 / w_o
         * of the blend's filter) kept the carrier on SyR-e's THOR, taken by
         * a load machine to 3,456 rpm in 0.1 s, to 3,450 rpm, 14 times
         * w_inject_max, where the plan's voltage less the carrier's left no
         * torque, and the drive lost the rotor */
        if ((c->w_inject_max > 0.0f) && drv->inject_on && (aw > c->w_inject_max) && drive_handed_over(drv)) {
            drv->inject_on = false;
            fs_smo_hold(&drv->smo, drv->hfi.n_settle);   /* ... and out */
        } else if (c->w_inject_max > 0.0f && !drv->inject_on && aw < 0.9f * c->w_inject_max) {
            drv->inject_on = true;
            /* the filters kept the carriers as they faded out (fs_hfi.h); the
             * observer with its filter's lag starts afresh, settling first: its
             * fast gains would take the stale carriers' angle */
            if (!drv->injecting && c->hfi.lag) {
                fs_hfi_restart(&drv->hfi, drv->blend.theta_hat, drv->blend.w_hat);   /* fades in (fs_hfi_fade_in) */
            } else if (!drv->injecting) {
                fs_hfi_set_angle(&drv->hfi, drv->blend.theta_hat, drv->blend.w_hat);
            } else {
                /* still injecting (the carrier was fading out): the injection's estimate carries on */
            }
            if (!drv->injecting) {
                fs_hfi_set_load(&drv->hfi, drv->blend.obs.T_d_hat);   /* the load it carries */
                /* the carrier fades in through the filters (below): a converged observer coasts on its
                 * model meanwhile. One that has not converged has no model verified to coast on (its load
                 * estimate off by dT turns the angle by p dT t^2 / (2 J) over the hold) and goes on
                 * correcting: the 2004 Prius MG2 held at 294 rpm by a load machine (B-REAL), its torque
                 * stepped to 486 N m, swung the estimated speed through the band (465, 675, then 278 rpm
                 * against the rotor's 294); held there, the observer's model decelerated at 13,700 rpm/s
                 * (50 N m of load error on the 0.035 kg m^2 rotor), 20 el.deg off at the hold's end, and the
                 * drive lost the rotor; correcting, it was back within 3 el.deg in 15 ms */
                if (drv->smo.converged) {
                    fs_smo_hold(&drv->smo, drv->hfi.n_settle);
                }
            }
        } else {
            /* the injection stays as it is: no w_inject_max, the speed within its hysteresis
             * (0.9 to 1 times w_inject_max), or not yet handed over to the SMO */
        }
    }
    /* The amplitude fades in and out over the filters' settling time, so
     * that the carrier current leaves no offset and the loops see no step
     * when the fundamental's source changes; the HFI runs until it is 0. */
    const float dg = 1.0f / (float)drv->hfi.n_settle;
    drv->hfi.gain = fs_clampf(drv->hfi.gain + (drv->inject_on ? dg : -dg), 0.0f, 1.0f);   /* mostly at an end */
    drv->injecting = drv->inject_on || drv->hfi.gain > 0.0f;
    return i_f;
}


/* The encoder's PLL at the drive's first two readings: the angle from the
 * first; in speed mode, from the second, the speed: the turn since the
 * first (the PLL's angle, a step at zero speed ago), and the speed loop
 * from there without a bump (no torque yet). A rotor already turning as
 * the drive starts (a flying start, a map's point at its speed) had the
 * PLL rise from zero at its bandwidth while the speed loop, acting on it,
 * asked for the current limit's braking torque: the README's 48 V example
 * at 4500 rpm tripped on overcurrent in 1.8 ms. In current mode no loop
 * acts on the speed (the decoupling takes the PLL's settling as a current
 * transient, 2.9 A on yang2022 at 300 rpm), and the PLL starts from zero
 * as before: seeded there too, the back-EMF observer running alongside
 * carried another start into its zero crossing 0.35 s later, and crossed
 * it worse (test_smo_low_speed: at -15 A a median of 13.7 el.deg over 16
 * initial angles against 2.7). A rotor at rest gives 0, as before. */
static void drive_pll_start(fs_drive *drv, float theta_enc)
{
    const fs_drive_config *c = &drv->cfg;
    if (!drv->pll_started) {
        fs_pll_reset(&drv->pll, theta_enc, 0.0f);
        drv->pll_started = true;
    } else {
        drv->pll_seeded = true;
        const float w0 = fs_wrap_pi(theta_enc - drv->pll.theta) / c->Ts;
        if ((w0 != 0.0f) && (c->mode == (int)FS_MODE_SPEED)) {
            fs_pll_reset(&drv->pll, theta_enc, w0);
            fs_speed_ctrl_preset(&drv->sc, w0 / (float)c->pole_pairs, 0.0f);
        }
    }
}

/* Angle and speed from the external input or the encoder (the PLL gives the speed). */
static void drive_sensor_angle(fs_drive *drv, const fs_drive_in *in, float *theta, float *w)
{
    const fs_drive_config *c = &drv->cfg;
    if (c->angle_source == (int)FS_ANGLE_EXTERNAL) {
        *theta = in->theta_e_ext;
        *w = in->w_e_ext;
        return;
    }
    float theta_enc = fs_wrap_pi((float)c->pole_pairs * in->theta_m_enc);
    if (!drv->pll_seeded) { drive_pll_start(drv, theta_enc); }
    /* The PLL's angle is its prediction for this sample. */
    (void)fs_pll_step(&drv->pll, fs_wrap_pi(theta_enc - drv->pll.theta));
    *theta = theta_enc;
    *w = drv->pll.w;
}

/* The blend's angle for the loops. With the injection's observer designed
 * with its filter's lag (fs_hfi.h, cfg.lag), the injection's own angle
 * where the blend weighs it (1 - g_w, while it is on and settled): the
 * blend's observer, at the paper's bandwidth for the back-EMF observer,
 * would lag it again under a load it does not know; its speed, smoother
 * than the injection's, stays the speed loop's. The same above the band
 * once the injection has stopped: the back-EMF observer's own angle (its
 * tracker, a motion observer at observer.bw_pll with the torque
 * feed-forward), which eq. (27) gives there and the blend's observer (at
 * the injection's w_o_blend, w_b_n / 5) only lags, by about
 * 0.27 p dT / (J w_o^2) under a load step it does not know (fs_motion_obs.h):
 * on motulator's 2.2 kW IPMSM with the designed defaults (50 rad/s) 16
 * el.deg at 0.7 x rated torque stepped on at 3000 rpm, 0.5 now, as the
 * back-EMF observer alone (bench/estimators.py, issue 34). Its speed stays
 * the loop's here too: on the back-EMF observer's speed, with a speed loop
 * not designed against that observer's PLL (angle = "smo" holds bw_speed
 * at bw_pll / 6), B-ROBUST's controllers with +-15 % parameter errors
 * limit-cycled at +-20 el.deg (34 at most, against 4.8 on this angle). Not
 * while the carrier runs or fades (up to injection.stop_rpm): the
 * observer then works on the SRFFs' fundamental, whose transient as the
 * carrier resumes the blend's observer smooths. */
static float drv_blend_theta(const fs_drive *drv)
{
    const fs_hfi *h = &drv->hfi;
    if (drv->blend.g_w >= 1.0f && !drv->injecting && drv->smo.converged && drv->cfg.smo.form == (int)FS_SMO_FORM_TRACKING) {
        return drv->smo.theta;   /* above the band (header) */
    }
    if (!drv->cfg.hfi.lag || !drv->inject_on || h->gain < 1.0f || h->k_settle > 0) { return drv->blend.theta_hat; }
    return fs_blend_angle_inline(drv->blend.theta_hat, h->theta, drv->blend.g_w);
}

/* Angle and speed from the configured source; *i_ab becomes the current the
 * loops use (the fundamental when injecting). */
static void drive_angle(fs_drive *drv, const fs_drive_in *in, fs_ab *i_ab, float *theta, float *w)
{
    const fs_drive_config *c = &drv->cfg;
    if (c->angle_source == (int)FS_ANGLE_SMO) {
        (void)fs_smo_step(&drv->smo, *i_ab, drive_smo_u(drv, *i_ab));
        if (in->sensorless != 0) {
            if (FS_WITH_IF_START && c->w_restart > 0.0f && drv->phase == (int)FS_PHASE_RUN) { fs_drive_if_restart(drv, in); }
            bool start = drv->phase == (int)FS_PHASE_START;
            *theta = start ? drv->ifs.theta : drv->smo.theta;
            *w = start ? drv->ifs.w : drv->smo.w;
            return;
        }
    }
    if (drive_injects(c) && c->mode != (int)FS_MODE_OFF) {   /* OFF injects nothing to estimate from */
        if (!drv->est_started) { fs_drive_start_estimators(drv, in); }
        *i_ab = drive_injection_step(drv, *i_ab);
        if (in->sensorless != 0) {
            bool blend = c->angle_source == (int)FS_ANGLE_BLEND;
            *theta = blend ? drv_blend_theta(drv) : drv->hfi.theta;
            *w = blend ? drv->blend.w_hat : drv->hfi.w;
            return;
        }
    }
    drive_sensor_angle(drv, in, theta, w);
}

/* With a flux map and flux weakening: the current for *T_ref within the
 * voltage limit (fs_fwmap.h) at this speed, MTPA below base speed; *T_ref
 * becomes the torque asked of it, and the speed PI's integral holds what
 * the limits took (its anti-windup). The voltage planned for: the
 * modulator's linear limit, less the resistive drop of the last current;
 * the trim (fs_fwmap_trim) takes the current loops' transient demand on
 * top of it back (the over-modulation beyond the linear limit, 5 % more,
 * covers them meanwhile). On the 2004 Prius MG2 (encoder, the speed held
 * at 1200..6000 rpm) the torque held is 1 to 4 % below the map's envelope
 * (design.envelope); planning for 95 % of the limit cost 6 to 12 %. */
static fs_dq drive_fw_map(fs_drive *drv, float u_dc, float w_e, float *T_ref)
{
    /* the last current (the map's point; on constants the loops' last) and the voltage asked */
    const fs_dq i0 = drive_map(drv) ? drv->cc.i0 : drv->cc.meas, u0 = drv->cc.u;
    /* while injecting the carrier takes its amplitude off the linear limit (zoo machine 47, injecting at
     * 1400 rpm: planned for the whole limit, the fundamental over-modulated under the carrier and the
     * injection's estimate ran 28 el.deg off) */
    const float u_hf = drv->injecting ? drv->hfi.gain * drv->hfi.u_amp : 0.0f;
    const float u_plan = FS_INV_SQRT3 * u_dc - u_hf;
    const float u_lim = u_plan - drv->cfg.R_s * sqrtf(i0.d * i0.d + i0.q * i0.q);
    const float x = fs_fwmap_ratio(&drv->fwm, u_lim, w_e);
    drv->fw_map_on = x > 1.0f;
    if (!drv->fw_map_on) {
        fs_fwmap_reset(&drv->fwm);
        return fs_mtpa_step(&drv->mtpa, *T_ref);
    }
    /* the flux at the last current, the map's (fs_current_ctrl_set_flux) or the constants' where the map plans
     * the flux weakening alone: the trim lowers x only on the limit */
    const fs_drive_config *c = &drv->cfg;
    const fs_dq psi0 = drive_map(drv) ? drv->cc.psi0 : (fs_dq){c->psi_f + (c->L_d * i0.d), c->L_q * i0.q};
    fs_fwmap_trim(&drv->fwm, sqrtf(u0.d * u0.d + u0.q * u0.q), u_plan, sqrtf(psi0.d * psi0.d + psi0.q * psi0.q), x);
    float T_real;
    const fs_dq i = fs_fwmap_step(&drv->fwm, x, *T_ref, &T_real);
    if (T_real != *T_ref) { fs_speed_ctrl_realised(&drv->sc, *T_ref, T_real); }
    *T_ref = T_real;
    return i;
}

/* The current reference of the closed-loop modes: the zero-current wait of
 * a recovery, polarity pulses, the I/f start, speed control (MTPA and flux
 * weakening) or the reference input; i_ab the loops' (fundamental) current. */
static fs_dq drive_current_ref(fs_drive *drv, const fs_drive_in *in, fs_ab i_ab, float w_e, bool weakens, float *T_ref)
{
    const fs_drive_config *c = &drv->cfg;
    fs_dq i_ref = {in->i_d_ref, in->i_q_ref};
    *T_ref = 0.0f;
    if (drv->phase == (int)FS_PHASE_RECOVER) {
        i_ref.d = i_ref.q = 0.0f;
        fs_drive_recover_step(drv, i_ab);
    } else if (drv->phase == (int)FS_PHASE_POLARITY) {
        i_ref = fs_drive_polarity_step(drv);
    } else if (FS_WITH_IF_START && c->mode == (int)FS_MODE_SPEED && in->sensorless && drv->phase == (int)FS_PHASE_START) {
        i_ref = fs_drive_if_step(drv, in, i_ab);
    } else if (c->mode == (int)FS_MODE_SPEED) {
        *T_ref = fs_speed_ctrl_step(&drv->sc, in->w_m_ref, w_e / (float)c->pole_pairs);
        if (drv->injecting && (drv->blend.g_w < 1.0f)) {   /* the torque's slew while injecting (fs_drive.h) */
            const float lim = c->T_slew * c->Ts;
            /* from the torque the last references make (the observers' feed-forward), but not from behind
             * the last reference the slew let through, in the direction asked: where something after the
             * speed loop took torque off the references for a sample (the flux-weakening plan's cap), the
             * next could rise only a slew step from the cut, and the speed loop's integral was wound back
             * to that, cut after cut (a new user's Baldor PM-SyRM at 4 x rated current on 3.6 ohm: 6..22 N m
             * of the 134 it may make while injecting, stuck at 170 rpm for 3000 asked; with no slew it ran) */
            const float dT0 = *T_ref - drv->T_ff;
            const float T_0 = (dT0 > 0.0f) ? fs_maxf(drv->T_ff, drv->T_slew) : fs_minf(drv->T_ff, drv->T_slew);
            const float dT = *T_ref - T_0;
            if ((fabsf(dT0) > lim) && (lim > 0.0f)) {
                const float T_s = (fabsf(dT) > lim) ? (T_0 + copysignf(lim, dT)) : *T_ref;
                fs_speed_ctrl_realised(&drv->sc, *T_ref, T_s);
                *T_ref = T_s;
            }
        }
        drv->T_slew = *T_ref;
        i_ref = weakens && drive_fw_plans(drv) ? drive_fw_map(drv, in->u_dc, w_e, T_ref) : fs_mtpa_step(&drv->mtpa, *T_ref);
        /* zou2021 eq. (30): i_d* = i_d0* + the filtered correction, i_q*
         * kept; then held inside the current limit circle, whose radius
         * leaves room for the carrier's peak while injecting */
        const float i_lim = c->i_max - (drv->injecting ? drv->hfi.gain * drv->i_hf : 0.0f);
        if (weakens && !drive_fw_plans(drv)) { i_ref.d += drv->fw.i_d; }   /* a map's flux weakening has its own trim */
        i_ref.d = fs_clamp_sym(i_ref.d, i_lim);
        float iq_max = sqrtf(i_lim * i_lim - i_ref.d * i_ref.d);
        float i_q0 = i_ref.q;
        i_ref.q = fs_clamp_sym(i_ref.q, iq_max);
        /* the circle took torque away: the speed PI's integral must not wind up */
        if (i_ref.q != i_q0) { fs_speed_ctrl_realised(&drv->sc, *T_ref, *T_ref * i_ref.q / i_q0); }
        if (drive_imc_depth(c)) {
            /* eqs. (32)-(33), gated by the polarity of i_d_fw (sec. 4.4;
             * the low-pass leaves a tail: 1 % of i_max counts as zero) */
            float i_amp = sqrtf(i_ref.d * i_ref.d + i_ref.q * i_ref.q);
            drv->alpha = fs_imc_depth_step(&drv->depth, i_amp, drv->fw.i_d < -0.01f * c->i_max);
        }
    } else {
        /* the current mode: the input's i_d_ref, i_q_ref as they are */
    }
    return i_ref;
}

/* The loss-of-lock residual of the estimator the loops use (fs_drive.h):
 * <= 1 on track, 0 while not monitored. Its signals are low-passed over a
 * quarter of lock_time first: single samples of a heterodyne or PLL error
 * are noisy, a lost estimator's are large for long. With the step's output
 * (NULL for the square wave), the checks that do not trust the estimator
 * (fs_monitor.h) join in. */
static float drive_lock_residual(fs_drive *drv, const fs_drive_in *in, const fs_drive_out *out, fs_ab i_ab,
                                 float cos_t, float sin_t)
{
    const fs_drive_config *c = &drv->cfg;
    const bool run = in->sensorless && drv->phase == (int)FS_PHASE_RUN;
    drv->t_quiet = run ? fs_maxf(drv->t_quiet - c->Ts, 0.0f) : drv->t_quiet;
    const bool settled = drv->t_quiet <= 0.0f;   /* after polarity detection (fs_drive_start.c) */
    const float g_w = out ? out->g_w : 0.0f;
    float r_mon = 0.0f;
    if (out != NULL) {
        const fs_monitor_in mi = {i_ab, {drv->u_hist[0].alpha, drv->u_hist[0].beta}, in->u_dc, out->theta_e, out->w_e, cos_t, sin_t,
                                  {out->i_d, out->i_q}, drv->T_ff,   /* the torque of out->i_d_ref, i_q_ref */
                                  {out->i_d_ref - out->i_d, out->i_q_ref - out->i_q},
                                  run && settled && (c->mode == (int)FS_MODE_CURRENT || c->mode == (int)FS_MODE_SPEED),
                                  out->over_modulation};
        r_mon = fs_monitor_step(&drv->mon, &mi);
        if (drv->mon.jumped) { fs_lock_latch(&drv->lock); }
    }
    const bool blend = c->angle_source == (int)FS_ANGLE_BLEND;
    const float b = 1.0f - drv->lock_a;
    /* each low-pass runs while its signal means something and starts from
     * 0 when it comes back, so that no stale value returns */
    const bool smo_on = run && drive_has_smo(c) && drv->smo.valid;
    /* the injection's error: the rotating carrier's once settled, over 15
     * deg; the square wave's PLL error once it has seen a carrier period,
     * over 30 deg (a rated load step swings it to about 28 on yu2022's
     * bench, U-XCOUPLE, and the estimate comes back) */
    const bool square = drive_square(c);
    const bool inj_on = run && settled && (square ? c->mode != (int)FS_MODE_OFF && drv->sw.k > 4
                                                  : drive_injects(c) && drv->injecting && drv->hfi.k_settle == 0);
    const float eps_inj = square ? drv->sw.eps : drv->hfi.eps;
    drv->lock_ri = smo_on ? drv->lock_ri + b * (drv->smo.r_i - drv->lock_ri) : 0.0f;
    drv->lock_es = smo_on ? drv->lock_es + b * (drv->smo.eps - drv->lock_es) : 0.0f;
    drv->lock_eh = inj_on ? drv->lock_eh + b * (eps_inj - drv->lock_eh) : 0.0f;
    const float r_smo = fs_maxf(0.5f * drv->lock_ri, 2.0f * fabsf(drv->lock_es));   /* 2 delta, sin 30 deg */
    const float r_inj = fabsf(drv->lock_eh) * (square ? 1.9098593f : 3.8197186f); /* 30 or 15 deg */
    float r = 0.0f;
    if (c->angle_source == (int)FS_ANGLE_SMO || (blend && g_w > 0.0f)) { r = r_smo; }
    if (c->angle_source == (int)FS_ANGLE_HFI || square || (blend && g_w < 1.0f)) { r = fs_maxf(r, r_inj); }
    /* an observer on track above the band, whose EMF is as large as its
     * speed says (not a PLL swinging at low speed: at least half of the
     * |w| psi_f / sqrt 2 its filter passes), against the blended angle;
     * on track by its own evidence too (`converged`, fs_smo.h): at
     * standstill the Baldor PM-SyRM's observer swung between -330 and +220
     * el. rad/s, never converged, while a load rolled the rotor back at
     * -10 el. rad/s, and the saliency's voltage under the rising q current
     * (L_q - L_d = 84 mH) lifted its |EMF| to 21 V, past the gate's 17 V at
     * -108 el. rad/s: a loss flagged with the blended angle within 2 el.deg */
    const float aw = fabsf(drv->smo.w);
    const bool cross = smo_on && blend && r_smo < 1.0f && aw >= drv->blend.cfg.w_upper && drv->smo.converged
                       && drv->smo.e_mag >= 0.35f * aw * c->psi_f;
    drv->lock_ex = cross ? drv->lock_ex + b * (fabsf(fs_wrap_pi(drv->smo.theta - drv->blend.theta_hat)) - drv->lock_ex)
                         : 0.0f;
    return fs_maxf(fs_maxf(r, drv->lock_ex * 1.2732395f), r_mon);                     /* 45 deg = pi/4 rad */
}

/* The phase currents in the stationary frame (the fundamental plane with
 * five phases). */
static fs_ab drive_clarke(const fs_drive_config *c, const float i_ph[])
{
    if (drive_five(c)) { return fs_vsd5_forward(i_ph).ab; }
    return fs_clarke(i_ph[0], i_ph[1], i_ph[2]);
}

/* The largest voltage the modulator realises without distortion. */
static float drive_u_lin(const fs_drive_config *c, float u_dc)
{
    return drive_five(c) ? u_dc * 0.5257311f : u_dc * 0.5773503f;   /* 1/(2 cos(pi/10)), 1/sqrt(3) */
}

/* Duties for the reference (fundamental plus carrier u_inj), dead-time
 * compensated; *u_f receives the realised fundamental voltage. OFF: 0.5. */
static bool drive_modulate(fs_drive *drv, const fs_drive_in *in, float u_dc, fs_ab u_ref, fs_ab u_inj,
                           float theta, float w_e, float duty[], fs_ab *u_f)
{
    const fs_drive_config *c = &drv->cfg;
    if (c->mode == (int)FS_MODE_OFF) {
        for (int k = 0; k < c->phases; ++k) { duty[k] = 0.5f; }
        u_f->alpha = u_f->beta = 0.0f;
        return false;
    }
    u_ref.alpha += u_inj.alpha;
    u_ref.beta += u_inj.beta;
    bool over = drive_five(c) ? fs_pwm5(u_ref, u_dc, duty, u_f) : fs_svpwm(u_ref, u_dc, duty, u_f);
    if (drive_five(c) && c->bw_xy > 0.0f) {   /* x-y current control on top of the nearest four vectors */
        fs_xyctrl_duties(fs_xyctrl_step(&drv->xy, in->i_ph, theta, w_e, u_dc), u_dc, duty);
    }
    if (FS_WITH_DTCOMP && c->dt_predict && c->t_dead_comp > 0.0f) { fs_dtcomp_step(&drv->dtc, in->i_ph, u_inj, duty); }
    else if (c->t_dead_comp > 0.0f) { fs_dtcomp_sampled(c->phases, in->i_ph, drv->dd_dead, c->i_dead_band, duty); }
    else { /* no dead-time compensation (t_dead_comp = 0) */ }
    u_f->alpha -= u_inj.alpha;   /* the fundamental part */
    u_f->beta -= u_inj.beta;
    return over;
}

/* zou2021: the rectifier stage for the period the duties act in, from the
 * input voltage sampled now and turned to that period's middle; returns
 * the period mean of the virtual dc link for the inverter stage. In the
 * linear region the reference is held inside the circle of sqrt3/2 V_im. */
static float drive_imc_rectify(fs_drive *drv, const fs_drive_in *in, fs_ab *u_ref, fs_drive_out *out)
{
    const fs_drive_config *c = &drv->cfg;
    fs_ab v = fs_clarke(in->u_in[0], in->u_in[1], in->u_in[2]);
    const float th = c->imc_w_grid * c->Ts * (c->delay + 0.5f);
    v = fs_inv_park((fs_dq){v.alpha, v.beta}, fs_cosf(th), fs_sinf(th));
    float u_pred[3];
    fs_inv_clarke(v, u_pred);
    const float V_im = sqrtf(v.alpha * v.alpha + v.beta * v.beta);
    const float m = sqrtf(u_ref->alpha * u_ref->alpha + u_ref->beta * u_ref->beta);
    float alpha = 0.0f;
    if (c->imc_region == (int)FS_IMC_LINEAR) {
        const float lim = fs_imc_vtr_max(FS_IMC_LINEAR, 0.0f) * V_im;
        if (m > lim) {
            u_ref->alpha *= lim / m;
            u_ref->beta *= lim / m;
        }
    } else if (c->imc_region == (int)FS_IMC_OM2) {
        alpha = drive_imc_depth(c) ? drv->alpha : fs_imc_alpha_for_vtr(V_im > 0.0f ? m / V_im : 0.0f);
    } else {
        /* FS_IMC_OM1, CASE 1 alone: the reference as it is, alpha 0 */
    }
    fs_imc_rectifier(u_pred, alpha, &out->rect);
    out->alpha = alpha;
    return out->rect.v_pn;
}

/* A flux map's values at the measured current i (fs_drive.h, map) for the
 * next step: the current loops' fluxes and incremental inductances, the
 * back-EMF observer's q secant inductance and active flux and its
 * incremental inductances (the transient, fs_smo.h); returns the
 * torque of the reference i_ref on the map (linearised at i). At the
 * voltage limit in flux weakening the current lags its reference: the
 * observer's model at the reference put its torque 20 % off there (the
 * Prius MG2 at 2800 rpm, i_d -76 A for -101 asked) and its angle ran away. */
static float drive_map_step(fs_drive *drv, fs_dq i, fs_dq i_ref)
{
    const fs_fluxmap_point p = fs_fluxmap_eval(&drv->map, i);
    /* the loops' gains on the incremental inductances continuous across the grid's lines (fs_fluxmap_slopes),
     * where the current is the machine's own. Not on the isotropic loops of an unknown angle, which take the
     * smaller of the cell's own two: at the start the current sits on the line i_d = 0, where SyR-e's THOR's
     * cells' slopes are 2.2 times apart, and their mean raised the loops' gains 1.6 times; the motion test's
     * lock read 40 % more spread, its first doublet fell short of the threshold and the second turned the
     * light rotor 36 el.deg, beyond the 33 its design bounds. Nor while injecting, where the loops' current
     * is the carrier filters' fundamental, whose steps from period to period are not the machine's and
     * which, along a cell's own axis, now moved the gains: zoo machine 0 on its identified map reversed
     * through the band 12 to 22 el.deg off, 3.3 to 3.6 on the cells' own slopes */
    fs_fluxmap_point p_cc = p;
    if (!drv->cc.iso && !drv->injecting) { fs_fluxmap_slopes(&drv->map, i, &p_cc.L_dd, &p_cc.L_qq); }
    fs_current_ctrl_set_flux(&drv->cc, i, &p_cc);
    if (drive_has_smo(&drv->cfg)) {
        const float L_q = fs_fluxmap_secant_q(&drv->map, i, &p);
        const float psi_a = p.psi.d - (L_q * i.d);
        fs_smo_set_model(&drv->smo, L_q, psi_a);
        /* the share of an angle error the EMF's angle shows on the map at this current (fs_smo.h,
         * fs_smo_speed), g = 1 + (L_qd i_q - (L_qq - L_q) i_d) / psi_a: the speed's weight is 1 - g */
        const float g = 1.0f + (((p.L_qd * i.q) - ((p.L_qq - L_q) * i.d)) / drv->smo.psi_run);
        drv->smo_k_speed = fs_clampf(1.0f - g, 0.0f, 1.0f);
        /* the map's transient only on the machine's own current: while injecting the observer's is the
         * filters' fundamental, whose steps from period to period are not the machine's (fs_smo.h) */
        drv->smo_at = p;
        drv->smo_transient = !drv->injecting;
    }
    const float psi_d = p.psi.d + p.L_dd * (i_ref.d - i.d), psi_q = p.psi.q + p.L_qq * (i_ref.q - i.q);
    return drv->k_T * (psi_d * i_ref.q - psi_q * i_ref.d);
}

/* The operating stage (fs_drive.h) from the phase, the source and weight,
 * and the flux-weakening current with hysteresis; open once halted (in the
 * step that halts, too). */
static int drive_stage(const fs_drive *drv, const fs_drive_in *in, float g_w, bool weakens)
{
    const fs_drive_config *c = &drv->cfg;
    if (c->mode != (int)FS_MODE_CURRENT && c->mode != (int)FS_MODE_SPEED) { return FS_STAGE_OPEN; }
    if (drv->phase == (int)FS_PHASE_POLARITY) { return FS_STAGE_POLARITY; }
    if (drv->phase >= (int)FS_PHASE_RECOVER) {   /* one comparison for both: RECOVER < HALT */
        return drv->phase == (int)FS_PHASE_RECOVER ? FS_STAGE_RECOVERY : FS_STAGE_OPEN;
    }
    if (in->sensorless && drv->phase == (int)FS_PHASE_START) { return FS_STAGE_START; }
    if (weakens) {
        const float lim = (drv->stage == (int)FS_STAGE_FLUX_WEAKENING ? -0.01f : -0.02f) * c->i_max;
        if (drv->fw.i_d < lim || drv->fw_map_on) { return FS_STAGE_FLUX_WEAKENING; }
    }
    if (!in->sensorless) { return FS_STAGE_SENSOR; }
    if (g_w <= 0.0f) { return FS_STAGE_INJECTION; }
    return g_w >= 1.0f ? FS_STAGE_BACKEMF : FS_STAGE_BLEND;
}

/* yu2022: the square-wave injection drive. The estimator runs at every
 * sample; the loops run at the carrier's zero crossings (every other
 * sample) on the fundamental current there, eq. (8), and their voltage
 * acts over the next whole window (k, k + 2) between zero crossings, so
 * that within each window the fundamental current rises linearly as eq. (8)
 * needs: computed at sample k, it acts from k + 2 with one period of delay
 * (from k without), i.e. one loop period (2 Ts) of delay. */
static void drive_step_square(fs_drive *drv, const fs_drive_in *in, fs_ab i_ab, fs_drive_out *out)
{
    const fs_drive_config *c = &drv->cfg;
    fs_swvi *sw = &drv->sw;
    /* cfg->delay, 0 or 1 (init refuses any other for the square wave); the constants as wide as d */
    const int d = (c->delay > 0.5f) ? (int)1 : (int)0;
    float theta, w_e;
    if (c->mode != (int)FS_MODE_OFF) {   /* OFF injects nothing to estimate from */
        if (!drv->est_started && !in->sensorless) {
            fs_swvi_reset(sw, fs_wrap_pi((float)c->pole_pairs * in->theta_m_enc), 0.0f);
        }
        drv->est_started = true;
        (void)fs_swvi_step(sw, i_ab);
    }
    if (in->sensorless != 0) {
        theta = sw->theta;
        w_e = sw->w;
    } else {
        drive_sensor_angle(drv, in, &theta, &w_e);
    }
    fs_drive_out *h = &drv->held;
    if (sw->ff_fresh && c->mode != (int)FS_MODE_OFF) {
        fs_dq i_dq = fs_park(sw->i_f, fs_cosf(theta), fs_sinf(theta));
        fs_dq i_ref = drive_current_ref(drv, in, sw->i_f, w_e, drive_weakens(c), &h->T_ref);
        fs_dq u_ref = fs_current_ctrl_step(&drv->cc, i_ref, i_dq, w_e);
        /* turned to the middle of the window it acts over */
        const int n_mid = (2 * d) + 1;   /* samples from k to the middle of the window (k + 2d, k + 2d + 2) */
        const float theta_u = theta + w_e * c->Ts * (float)n_mid;
        const float cu = fs_cosf(theta_u), su = fs_sinf(theta_u);
        fs_ab u = fs_inv_park(u_ref, cu, su);
        /* what the modulator realises beside the carrier (anti-windup) */
        const float u_max = drive_u_lin(c, in->u_dc) - c->swvi.u_h, m = sqrtf(u.alpha * u.alpha + u.beta * u.beta);
        h->over_modulation = m > u_max;
        if (h->over_modulation) {
            const float s = u_max > 0.0f ? u_max / m : 0.0f;
            u.alpha *= s;
            u.beta *= s;
        }
        fs_dq u_real = fs_park(u, cu, su);
        fs_current_ctrl_update(&drv->cc, u_real);
        if (d == 0) { drv->u_ff_hold = u; } else { drv->u_ff_next = u; }
        h->i_d = i_dq.d;
        h->i_q = i_dq.q;
        h->i_d_ref = i_ref.d;
        h->i_q_ref = i_ref.q;
        h->u_d = u_real.d;
        h->u_q = u_real.q;
    } else if (d == 1 && !sw->ff_fresh) {
        drv->u_ff_hold = drv->u_ff_next;   /* the window (k + 1, k + 3) starts at the next update */
    } else {
        /* the held voltage stands: between the loops' samples without a delay, or OFF */
    }
    fs_ab u_f;
    fs_ab u_inj = c->mode == (int)FS_MODE_OFF ? (fs_ab){0.0f, 0.0f} : sw->u;
    (void)drive_modulate(drv, in, in->u_dc, drv->u_ff_hold, u_inj, theta, w_e, out->duty, &u_f);   /* over-modulation: the window's own check (h) */

    out->theta_e = theta;
    out->w_e = w_e;
    out->i_d = h->i_d;
    out->i_q = h->i_q;
    out->i_d_ref = h->i_d_ref;
    out->i_q_ref = h->i_q_ref;
    out->T_ref = h->T_ref;
    out->u_d = h->u_d;
    out->u_q = h->u_q;
    out->over_modulation = h->over_modulation;
    out->theta_est = sw->theta;
    out->w_est = sw->w;
    out->est_valid = sw->k > 4;
    out->phase = FS_PHASE_RUN;
    out->i_d_fw = 0.0f;
    out->g_w = 0.0f;
    out->injecting = c->mode != (int)FS_MODE_OFF;
    out->i_hf_d = sw->i_h.d;
    out->i_hf_q = sw->i_h.q;
    /* loss of lock (fs_drive.h), at the loops' rate */
    if (c->lock_time > 0.0f && sw->ff_fresh) {
        h->lock_resid = drive_lock_residual(drv, in, NULL, (fs_ab){0.0f, 0.0f}, 1.0f, 0.0f);
        h->lock_lost = fs_lock_step(&drv->lock, h->lock_resid);
    }
    out->lock_resid = h->lock_resid;
    out->lock_lost = h->lock_lost;
    drv->stage = drive_stage(drv, in, 0.0f, drive_weakens(c));
    out->stage = drv->stage;
    out->recoveries = 0;
    if (fabsf(w_e) > drv->w_over) { fs_drive_halt(drv, FS_FAULT_OVERSPEED, out); }
}

/* Online R_s and psi_f (fs_param_adapt.h), learnt while the loops run
 * sensorless: the SMO's model, the injection's carrier phase and the
 * current loop's feed-forward take them. */
static void drive_adapt(fs_drive *drv, const fs_drive_in *in, fs_dq u, fs_dq i, float w_e, bool closed_loop)
{
    const bool learn = closed_loop && in->sensorless && drv->phase == (int)FS_PHASE_RUN;
    if (fs_param_adapt_step(&drv->adapt, u, i, w_e, learn)) {
        drv->smo.cfg.R_s = drv->adapt.R_s;
        drv->cc.cfg.psi_f = drv->adapt.psi_f;
        /* the injection's phase compensation (trigonometry): on a 1 % move */
        if (drive_injects(&drv->cfg) && fabsf(drv->adapt.R_s - drv->hfi.cfg.R_s) > 0.01f * drv->cfg.R_s) {
            fs_hfi_set_resistance(&drv->hfi, drv->adapt.R_s);
        }
    }
}

/* Halted (FS_PHASE_HALT, fs_drive_protect.h): zero voltage, the fault held. */
static void drive_step_halt(const fs_drive *drv, fs_ab i_ab, fs_drive_out *out)
{
    *out = (fs_drive_out){0};
    for (int k = 0; k < drv->cfg.phases; ++k) { out->duty[k] = 0.5f; }
    fs_dq i = fs_park(i_ab, 1.0f, 0.0f);
    out->i_d = i.d;
    out->i_q = i.q;
    out->phase = FS_PHASE_HALT;
    out->stage = FS_STAGE_OPEN;
    out->fault = drv->fault;
    out->recoveries = drv->recoveries;
    out->lock_lost = drv->fault == (int)FS_FAULT_LOCK;
}

void fs_drive_step(fs_drive *drv, const fs_drive_in *in, fs_drive_out *out)
{
    const fs_drive_config *c = &drv->cfg;
    if (FS_WITH_IDENT && c->mode == (int)FS_MODE_IDENTIFY) {
        fs_drive_ident_step(drv, in, out);
        return;
    }
    fs_ab i_ab = drive_clarke(c, in->i_ph);
    if (drv->phase == (int)FS_PHASE_HALT) {
        drive_step_halt(drv, i_ab, out);
        return;
    }
    out->rect.iv[0] = out->rect.iv[1] = (fs_imc_interval){0, 0, 0.0f};   /* field by field: a whole struct's literal is a memset call */
    out->rect.v_pn = 0.0f;
    out->rect.sector = 0;
    out->rect.case2 = false;
    out->alpha = 0.0f;
    out->fault = FS_FAULT_NONE;
    if (drive_square(c)) {
        drive_step_square(drv, in, i_ab, out);
        return;
    }
    float theta, w_e;
    fs_ab i_loop = i_ab;
    drive_angle(drv, in, &i_loop, &theta, &w_e);

    fs_dq u_ref = {0.0f, 0.0f};
    fs_dq i_ref = {0.0f, 0.0f};
    float T_ref = 0.0f;
    bool closed_loop = (c->mode == (int)FS_MODE_CURRENT || c->mode == (int)FS_MODE_SPEED);
    const bool weakens = drive_weakens(c);   /* once: the compiler cannot keep it across the stores below */

    if (c->mode == (int)FS_MODE_VOLTAGE_DQ || c->mode == (int)FS_MODE_VF) {
        theta = drv->theta_ol;
        w_e = in->w_e_ref;
        drv->theta_ol = fs_wrap_pi(drv->theta_ol + c->Ts * in->w_e_ref);
        if (c->mode == (int)FS_MODE_VOLTAGE_DQ) {
            u_ref.d = in->u_d_ref;
            u_ref.q = in->u_q_ref;
        } else {
            u_ref.q = fs_signf(in->w_e_ref) * (c->vf_boost + c->vf_gain * fabsf(in->w_e_ref));
        }
    }
    float cos_t = fs_cosf(theta), sin_t = fs_sinf(theta);
    fs_dq i_dq = fs_park(i_loop, cos_t, sin_t);
    bool starting = in->sensorless && drv->phase == (int)FS_PHASE_START;
    bool polarity = drv->phase == (int)FS_PHASE_POLARITY;
    const bool recovering = drv->phase == (int)FS_PHASE_RECOVER;

    if (closed_loop) {
        /* the frame's axes not yet found: loops that hold in any frame (fs_current_ctrl.h): an I/f
         * start, a recovery, and the polarity test's lock, where the injection finds the axis; its pulses
         * and its push act on the axis found, pi-ambiguous only, which swaps no inductance (with the
         * isotropic loops there a 30 kW traction machine's 74 A pulses no longer decided) */
        const bool locking = polarity && (drive_motion(c) ? (drv->mt.stage == (int)FS_MOTION_LOCK)
                                                           : (drv->pol.stage == (int)FS_POLARITY_LOCK));
        const bool unsure = in->sensorless && (starting || locking || recovering);
        if (unsure != drv->cc.iso_asked) {
            fs_current_ctrl_set_isotropic(&drv->cc, unsure);
        }
        i_ref = drive_current_ref(drv, in, i_loop, w_e, weakens, &T_ref);
        /* on the fluxes where the angle is measured (fs_current_ctrl.h); on an estimate they lost SyR-e's
         * THOR held at 4,147 rpm by a load machine, and the Prius MG2 stepped to its full torque at 294 rpm,
         * where the loops on the currents did not (the map's flux at the measured current is the
         * machine's in the machine's frame only: an estimate's error turns the magnet's flux into q) */
        if (drive_map(drv) && !in->sensorless) {
            fs_current_ctrl_set_flux_ref(&drv->cc, fs_fluxmap_eval(&drv->map, i_ref).psi);
        }
        u_ref = fs_current_ctrl_step(&drv->cc, i_ref, i_dq, w_e);
    }

    /* The voltage acts from the next update instant for one period: rotate it
     * by the angle the rotor turns until the middle of that period. */
    const float _Complex turn = fs_cis_small(w_e * c->Ts * (c->delay + 0.5f));   /* e^{j theta_u} = e^{j theta} e^{j turn} */
    const float tc = fs_cre(turn), ts = fs_cim(turn);
    const float cos_u = cos_t * tc - sin_t * ts, sin_u = sin_t * tc + cos_t * ts;
    fs_ab u_ab_ref = fs_inv_park(u_ref, cos_u, sin_u);
    fs_ab u_inj = {0.0f, 0.0f};
    if (drv->injecting && c->mode != (int)FS_MODE_OFF) { u_inj = drv->hfi.u; }   /* eq. (22) */
    fs_ab u_ab;
    float u_dc = in->u_dc;
    if (drive_imc(c)) { u_dc = drive_imc_rectify(drv, in, &u_ab_ref, out); }
    out->over_modulation = drive_modulate(drv, in, u_dc, u_ab_ref, u_inj, theta, w_e, out->duty, &u_ab);
    drv->u_hist[1] = drv->u_hist[0];
    drv->u_hist[0] = u_ab;
    fs_dq u_real = fs_park(u_ab, cos_u, sin_u);
    const bool weakening = weakens && !starting && !polarity && !recovering;
    if (closed_loop) {   /* anti-windup; held: the regulators keep PART_1's input (fs_fw.h) */
        fs_current_ctrl_update_held(&drv->cc, u_real,
                                    weakening && c->fw_hold ? fs_fw_hold(&drv->fw, u_ref, u_real, w_e) : u_real);
    }
    if (FS_WITH_ADAPT && c->adapt.T_f > 0.0f) { drive_adapt(drv, in, u_real, i_dq, w_e, closed_loop); }
    if (weakening && !drive_fw_plans(drv)) {
        (void)fs_fw_step(&drv->fw, u_ref.q - u_real.q, w_e);   /* eq. (26): dv_q */
    }

    out->theta_e = theta;
    out->w_e = w_e;
    out->i_d = i_dq.d;
    out->i_q = i_dq.q;
    out->i_d_ref = i_ref.d;
    out->i_q_ref = i_ref.q;
    out->T_ref = T_ref;
    out->u_d = u_real.d;
    out->u_q = u_real.q;
    drv->T_ff = drive_map(drv) ? drive_map_step(drv, i_dq, i_ref)   /* the monitor's now, the observers' next step */
                             : drive_torque_at(c, drv->k_T, i_ref);
    out->theta_est = theta;
    out->w_est = w_e;
    out->est_valid = true;
    out->g_w = 1.0f;
    if (c->angle_source == (int)FS_ANGLE_SMO) {
        out->theta_est = drv->smo.theta;
        out->w_est = drv->smo.w;
        out->est_valid = drv->smo.valid;
    } else if (c->angle_source == (int)FS_ANGLE_HFI) {
        out->theta_est = drv->hfi.theta;
        out->w_est = drv->hfi.w;
        out->est_valid = drv->phase == (int)FS_PHASE_RUN && drv->injecting && drv->hfi.k_settle == 0;
        out->g_w = 0.0f;
    } else if (c->angle_source == (int)FS_ANGLE_BLEND) {
        out->theta_est = drv->blend.theta_hat;
        out->w_est = drv->blend.w_hat;
        out->est_valid = drv->phase == (int)FS_PHASE_RUN && drv->est_started && drv->hfi.k_settle == 0;
        out->g_w = drv->blend.g_w;
    } else {
        /* the encoder or an external angle: the loops' own angle and speed (above) */
    }
    out->injecting = drv->injecting && c->mode != (int)FS_MODE_OFF;
    out->phase = drv->phase;
    out->i_d_fw = weakens ? drv->fw.i_d : 0.0f;
    out->i_hf_d = out->i_hf_q = 0.0f;
    out->lock_resid = 0.0f;
    out->lock_lost = false;
    if (c->lock_time > 0.0f) {
        out->lock_resid = drive_lock_residual(drv, in, out, i_loop, cos_t, sin_t);   /* the current the loops used, as out->i_d, i_q are it in their frame */
        out->lock_lost = fs_lock_step(&drv->lock, out->lock_resid);
        if (out->lock_lost && c->lock_recover) { fs_drive_lock_lost(drv, out); }   /* recover, or halt (fs_drive_protect.h) */
    }
    drv->stage = drive_stage(drv, in, out->g_w, weakens);
    out->stage = drv->stage;
    out->recoveries = drv->recoveries;
    if (fabsf(w_e) > drv->w_over) { fs_drive_halt(drv, FS_FAULT_OVERSPEED, out); }
}
