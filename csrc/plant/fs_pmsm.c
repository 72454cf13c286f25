#include "fs_pmsm.h"

#include <math.h>
#include <string.h>

int fs_pmsm_init(fs_pmsm *m, const fs_pmsm_config *cfg)
{
    m->cfg = *cfg;
    if (cfg->pole_pairs < 1 || !(cfg->R_s >= 0.0) || !(cfg->J > 0.0)) return -1;
    if (!(cfg->B >= 0.0) || !(cfg->T_coulomb >= 0.0)) return -1;
    if (cfg->T_coulomb > 0.0 && !(cfg->w_coulomb > 0.0)) return -1;
    if (fs_mag_init(&m->mag, &cfg->mag) != 0) return -1;
    double J_tot = cfg->J + cfg->J_load;
    m->k_p_load = 2.0 * cfg->load_bandwidth * J_tot;   /* double pole at -bandwidth */
    m->k_i_load = cfg->load_bandwidth * cfg->load_bandwidth * J_tot;
    if (cfg->load_kind == FS_LOAD_SPEED_PI && !(cfg->load_bandwidth > 0.0)) return -1;
    return 0;
}

static double friction(const fs_pmsm_config *c, double w)
{
    double f = c->B * w;
    if (c->T_coulomb > 0.0) {
        double s = w / c->w_coulomb;
        f += c->T_coulomb * (s > 1.0 ? 1.0 : (s < -1.0 ? -1.0 : s));
    }
    return f;
}

/* Torque the load machine applies against the motor (PI on speed). */
static double load_machine_torque(const fs_pmsm *m, const double *x, const fs_pmsm_input *in)
{
    return -(m->k_p_load * (in->w_load - x[FS_X_W_M]) + x[FS_X_LOAD_I]);
}

void fs_pmsm_outputs(fs_pmsm *m, const double *x, const fs_pmsm_input *in,
                     double *i_d, double *i_q, double *T_e, double *T_shaft)
{
    fs_mag_current(&m->mag, x[FS_X_PSI_D], x[FS_X_PSI_Q], i_d, i_q);
    *T_e = 1.5 * m->cfg.pole_pairs * (x[FS_X_PSI_D] * *i_q - x[FS_X_PSI_Q] * *i_d);
    double T = in->T_load;
    if (m->cfg.load_kind == FS_LOAD_SPEED_PI) T += load_machine_torque(m, x, in);
    *T_shaft = T;
}

/* The right-hand side with the rotor angle's cosine and sine given. */
static void deriv_cs(fs_pmsm *m, const double *x, const fs_pmsm_input *in, double cs, double sn,
                     double *dx)
{
    const fs_pmsm_config *c = &m->cfg;
    double i_d, i_q, T_e, T_shaft;
    fs_pmsm_outputs(m, x, in, &i_d, &i_q, &T_e, &T_shaft);
    double w_m = x[FS_X_W_M];  /* SPEED_IDEAL: follows dw_load, reset each sample */
    double w_e = c->pole_pairs * w_m;
    double u_d = cs * in->u_alpha + sn * in->u_beta;
    double u_q = -sn * in->u_alpha + cs * in->u_beta;

    dx[FS_X_PSI_D] = u_d - c->R_s * i_d + w_e * x[FS_X_PSI_Q];
    dx[FS_X_PSI_Q] = u_q - c->R_s * i_q - w_e * x[FS_X_PSI_D];
    switch (c->load_kind) {
    case FS_LOAD_SPEED_IDEAL:
        dx[FS_X_W_M] = in->dw_load;
        dx[FS_X_LOAD_I] = 0.0;
        break;
    case FS_LOAD_SPEED_PI:
        dx[FS_X_W_M] = (T_e - T_shaft - friction(c, w_m)) / (c->J + c->J_load);
        dx[FS_X_LOAD_I] = m->k_i_load * (in->w_load - w_m);
        break;
    default:
        dx[FS_X_W_M] = (T_e - T_shaft - friction(c, w_m)) / c->J;
        dx[FS_X_LOAD_I] = 0.0;
    }
    dx[FS_X_THETA_M] = w_m;
    dx[FS_X_E_IN] = 1.5 * (u_d * i_d + u_q * i_q);
    dx[FS_X_E_CU] = 1.5 * c->R_s * (i_d * i_d + i_q * i_q);
    dx[FS_X_E_AIRGAP] = T_e * w_m;
    dx[FS_X_UD_INT] = u_d;
    dx[FS_X_UQ_INT] = u_q;
}

void fs_pmsm_deriv(fs_pmsm *m, const double *x, const fs_pmsm_input *in, double *dx)
{
    double th = m->cfg.pole_pairs * x[FS_X_THETA_M];
    deriv_cs(m, x, in, cos(th), sin(th), dx);
}

/* The right-hand side at a stage whose angle is the step's start angle
 * (cos c0, sin s0) plus a small d: cos and sin of d by their Taylor series,
 * within 1e-10 for |d| <= 0.15 rad (a fraction of the cost of cos and sin),
 * and by the library otherwise. */
static void deriv_stage(fs_pmsm *m, const double *x0, const double *y, const fs_pmsm_input *in,
                        double c0, double s0, double *dx)
{
    double d = m->cfg.pole_pairs * (y[FS_X_THETA_M] - x0[FS_X_THETA_M]);
    double cd, sd;
    if (fabs(d) <= 0.15) {
        double d2 = d * d;
        cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 * (1.0 / 720.0)));
        sd = d * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0 - d2 * (1.0 / 5040.0))));
    } else {
        cd = cos(d);
        sd = sin(d);
    }
    deriv_cs(m, y, in, c0 * cd - s0 * sd, s0 * cd + c0 * sd, dx);
}

void fs_pmsm_rk4(fs_pmsm *m, double *x, const fs_pmsm_input *in, double h)
{
    double k1[FS_X_N], k2[FS_X_N], k3[FS_X_N], k4[FS_X_N], y[FS_X_N];
    double th = m->cfg.pole_pairs * x[FS_X_THETA_M];
    double c0 = cos(th), s0 = sin(th);
    deriv_cs(m, x, in, c0, s0, k1);
    for (int n = 0; n < FS_X_N; ++n) y[n] = x[n] + 0.5 * h * k1[n];
    deriv_stage(m, x, y, in, c0, s0, k2);
    for (int n = 0; n < FS_X_N; ++n) y[n] = x[n] + 0.5 * h * k2[n];
    deriv_stage(m, x, y, in, c0, s0, k3);
    for (int n = 0; n < FS_X_N; ++n) y[n] = x[n] + h * k3[n];
    deriv_stage(m, x, y, in, c0, s0, k4);
    for (int n = 0; n < FS_X_N; ++n) x[n] += h / 6.0 * (k1[n] + 2.0 * k2[n] + 2.0 * k3[n] + k4[n]);
}
