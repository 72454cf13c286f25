#include "fs_drive_ident.h"
#include "fs_math.h"

FS_COLD fs_status fs_drive_ident_init(fs_drive *drv, const fs_drive_config *cfg)
{
    fs_status ret;
    if (cfg->phases != 3) { drv->fail = "phases"; ret = FS_ERR_MODE; }
    else if (cfg->converter != (int)FS_CONV_VSI) { drv->fail = "converter"; ret = FS_ERR_MODE; }
    else if (!fs_pos(cfg->T_pwm) || !(cfg->T_pwm >= cfg->Ts)) { drv->fail = "T_pwm"; ret = FS_ERR_TS; }
    else {
        fs_ident_config ic = cfg->ident;
        ic.Ts = cfg->Ts;
        ic.T_pwm = cfg->T_pwm;
        ic.delay = cfg->delay;
        ic.pole_pairs = cfg->pole_pairs;
        ic.i_max = cfg->i_max;
        fs_status st = fs_ident_init(&drv->ident, &ic);
        if (st != FS_OK) {
            drv->fail = (st == FS_ERR_TS) ? "Ts" : (st == FS_ERR_POLE_PAIRS) ? "pole_pairs" : (st == FS_ERR_I_MAX) ? "i_max"
                      : ((ic.delay != 0.0f) && (ic.delay != 1.0f)) ? "delay" : "ident";
            ret = st;
        }
        else {
            drv->cfg = *cfg;
            ret = FS_OK;
        }
    }
    return ret;
}

void fs_drive_ident_step(fs_drive *drv, const fs_drive_in *in, fs_drive_out *out)
{
    fs_ident *id = &drv->ident;
    const fs_ab i_ab = fs_clarke(in->i_ph[0], in->i_ph[1], in->i_ph[2]);
    const fs_ab u = fs_ident_step(id, i_ab, in->u_dc);
    static const fs_drive_out none = { 0 };
    *out = none;
    fs_ab u_real;
    out->over_modulation = fs_svpwm(u, in->u_dc, out->duty, &u_real);
    /* the frame the step works in: the standstill steps' axis, then the running frame */
    const float th = (id->step < (int)FS_IDENT_SPIN) ? id->theta_s : id->theta;
    const float ct = fs_cosf(th);
    const float st = fs_sinf(th);
    const fs_dq i = fs_park(i_ab, ct, st);
    const fs_dq v = fs_park(u_real, ct, st);
    out->theta_e = th;
    out->theta_est = th;
    out->w_e = id->w;
    out->w_est = id->w;
    out->i_d = i.d;
    out->i_q = i.q;
    out->u_d = v.d;
    out->u_q = v.q;
    out->phase = FS_PHASE_RUN;
    out->stage = FS_STAGE_OPEN;
    out->g_w = 1.0f;
    out->ident_step = id->step;
}
