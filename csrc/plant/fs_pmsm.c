#include "fs_pmsm.h"
#include "fs_magnetic_inline.h"

#include <math.h>
#include <string.h>

/* x >= 0 (or > 0) and finite */
static int nonneg(double x) { return x >= 0.0 && isfinite(x); }
static int pos(double x) { return x > 0.0 && isfinite(x); }

/* Spatial harmonics at electrical angle theta (cos cs, sin sn): the
 * magnet's harmonic flux h (rotor frame) and the flux transform M = I + A,
 * with their derivatives in theta (fs_pmsm.h). */
typedef struct {
    double h_d, h_q, dh_d, dh_q;      /* psi_h and d psi_h / d theta */
    double a_d, a_q, a_x;             /* A = [[a_d, a_x], [a_x, a_q]] */
    double da_d, da_q, da_x;          /* dA / d theta */
    double c_cog, s_cog;              /* cos, sin of cog_order theta */
} fs_harm_at;

static inline void harm_at(const fs_pmsm *m, double cs, double sn, fs_harm_at *g)
{
    const fs_pmsm_config *c = &m->cfg;
    /* e^{j 6 theta} and e^{j 12 theta} by products, no trigonometry */
    const double c2 = cs * cs - sn * sn, s2 = 2.0 * cs * sn;
    const double c3 = c2 * cs - s2 * sn, s3 = s2 * cs + c2 * sn;
    const double c6 = c3 * c3 - s3 * s3, s6 = 2.0 * c3 * s3;
    const double c12 = c6 * c6 - s6 * s6, s12 = 2.0 * c6 * s6;
    /* 5th and 11th turn backwards, 7th and 13th forwards: in the rotor
     * frame psi_5 e^{-j6th} + psi_7 e^{j6th} + psi_11 e^{-j12th} + psi_13 e^{j12th} */
    const double p6 = c->psi_h[0] + c->psi_h[1], m6 = c->psi_h[1] - c->psi_h[0];
    const double p12 = c->psi_h[2] + c->psi_h[3], m12 = c->psi_h[3] - c->psi_h[2];
    g->h_d = p6 * c6 + p12 * c12;
    g->h_q = m6 * s6 + m12 * s12;
    g->dh_d = -6.0 * p6 * s6 - 12.0 * p12 * s12;
    g->dh_q = 6.0 * m6 * c6 + 12.0 * m12 * c12;
    g->a_d = c->sal6[0] * c6 + c->sal12[0] * c12;
    g->a_q = c->sal6[1] * c6 + c->sal12[1] * c12;
    g->a_x = c->sal6[2] * s6 + c->sal12[2] * s12;
    g->da_d = -6.0 * c->sal6[0] * s6 - 12.0 * c->sal12[0] * s12;
    g->da_q = -6.0 * c->sal6[1] * s6 - 12.0 * c->sal12[1] * s12;
    g->da_x = 6.0 * c->sal6[2] * c6 + 12.0 * c->sal12[2] * c12;
    switch (c->cog_order) {
    case 6: g->c_cog = c6; g->s_cog = s6; break;
    case 12: g->c_cog = c12; g->s_cog = s12; break;
    case 18: g->c_cog = c12 * c6 - s12 * s6; g->s_cog = s12 * c6 + c12 * s6; break;
    default: g->c_cog = c12 * c12 - s12 * s12; g->s_cog = 2.0 * c12 * s12; break;   /* 24 */
    }
}

/* The base model's flux phi = p0 + M (psi - h - p0) (fs_pmsm.h). */
static inline void harm_phi(const fs_pmsm *m, const double *x, const fs_harm_at *g, double *r_d, double *r_q,
                            double *phi_d, double *phi_q)
{
    *r_d = x[FS_X_PSI_D] - g->h_d - m->p0_d;
    *r_q = x[FS_X_PSI_Q] - g->h_q - m->p0_q;
    *phi_d = m->p0_d + (1.0 + g->a_d) * *r_d + g->a_x * *r_q;
    *phi_q = m->p0_q + g->a_x * *r_d + (1.0 + g->a_q) * *r_q;
}

/* Currents i = M^T f(phi) and, if asked, dW/dtheta at constant flux, the
 * torque's angle term: f^T (A' r - M h') - T_cog(theta) / (3/2 p). */
static void harm_current(fs_pmsm *m, const double *x, double cs, double sn, double *i_d, double *i_q,
                         double *dW)
{
    fs_harm_at g;
    harm_at(m, cs, sn, &g);
    double r_d, r_q, phi_d, phi_q, f_d, f_q;
    harm_phi(m, x, &g, &r_d, &r_q, &phi_d, &phi_q);
    fs_mag_current(&m->mag, phi_d, phi_q, &f_d, &f_q);
    *i_d = (1.0 + g.a_d) * f_d + g.a_x * f_q;
    *i_q = g.a_x * f_d + (1.0 + g.a_q) * f_q;
    if (dW) {
        const double v_d = g.da_d * r_d + g.da_x * r_q - ((1.0 + g.a_d) * g.dh_d + g.a_x * g.dh_q);
        const double v_q = g.da_x * r_d + g.da_q * r_q - (g.a_x * g.dh_d + (1.0 + g.a_q) * g.dh_q);
        /* cogging: W_cog = T_cog cos(n theta) / (3/2 p n), so -3/2 p dW_cog/dtheta = T_cog sin(n theta) */
        *dW = f_d * v_d + f_q * v_q - m->cfg.T_cog * g.s_cog / (1.5 * m->cfg.pole_pairs);
    }
}


fs_status fs_pmsm_init(fs_pmsm *m, const fs_pmsm_config *cfg)
{
    if (!m || !cfg) return FS_ERR_NULL;
    m->cfg = *cfg;
    m->R_s0 = cfg->R_s;
    m->psi_f30 = cfg->psi_f3;
    if (cfg->pole_pairs < 1) return FS_ERR_POLE_PAIRS;
    if (!nonneg(cfg->R_s)) return FS_ERR_RS;
    if (!pos(cfg->J)) return FS_ERR_J;
    if (!nonneg(cfg->B) || !nonneg(cfg->T_coulomb) || !nonneg(cfg->J_load) || !isfinite(cfg->w_coulomb)
        || !isfinite(cfg->load_bandwidth))
        return FS_ERR_PARAM;
    if ((cfg->T_coulomb > 0.0 || cfg->load_kind == FS_LOAD_BRAKE) && !(cfg->w_coulomb > 0.0)) return FS_ERR_PARAM;
    if (cfg->load_kind < FS_LOAD_TORQUE || cfg->load_kind > FS_LOAD_BRAKE) return FS_ERR_MODE;
    if (cfg->load_kind == FS_LOAD_SPEED_PI && !(cfg->load_bandwidth > 0.0)) return FS_ERR_PARAM;
    fs_status st = fs_mag_init(&m->mag, &cfg->mag);
    if (st != FS_OK) return st;
    double J_tot = cfg->J + cfg->J_load;
    m->k_p_load = 2.0 * cfg->load_bandwidth * J_tot;   /* double pole at -bandwidth */
    m->k_i_load = cfg->load_bandwidth * cfg->load_bandwidth * J_tot;
    if (!isfinite(m->k_i_load)) return FS_ERR_PARAM;
    if (cfg->phases != 3 && cfg->phases != 5) return FS_ERR_PARAM;
    m->harm = 0;
    for (int k = 0; k < 4; ++k) {
        if (!isfinite(cfg->psi_h[k])) return FS_ERR_PARAM;
        m->harm |= cfg->psi_h[k] != 0.0;
    }
    for (int k = 0; k < 3; ++k) {
        /* M = I + A must stay invertible (and near I: a transform, not a new machine) */
        if (!(fabs(cfg->sal6[k]) + fabs(cfg->sal12[k]) < 0.5)) return FS_ERR_PARAM;
        m->harm |= cfg->sal6[k] != 0.0 || cfg->sal12[k] != 0.0;
    }
    if (!isfinite(cfg->T_cog)) return FS_ERR_PARAM;
    m->harm |= cfg->T_cog != 0.0;
    if (cfg->T_cog != 0.0 && cfg->cog_order != 6 && cfg->cog_order != 12 && cfg->cog_order != 18
        && cfg->cog_order != 24)
        return FS_ERR_PARAM;
    if (m->harm && cfg->phases != 3) return FS_ERR_PARAM;
    if (fs_iron_check(&cfg->iron) != FS_OK) return FS_ERR_PARAM;
    fs_mag_flux(&m->mag, 0.0, 0.0, &m->p0_d, &m->p0_q);
    m->inv_L_d3 = m->inv_L_q3 = 0.0;
    if (cfg->phases == 5) {
        if (!pos(cfg->L_d3)) return FS_ERR_LD;
        if (!pos(cfg->L_q3)) return FS_ERR_LQ;
        if (!nonneg(cfg->psi_f3)) return FS_ERR_PSI_F;
        m->inv_L_d3 = 1.0 / cfg->L_d3;
        m->inv_L_q3 = 1.0 / cfg->L_q3;
    }
    return FS_OK;
}

void fs_pmsm_initial_state(fs_pmsm *m, double *x)
{
    for (int n = 0; n < FS_X_N; ++n) x[n] = 0.0;
    fs_mag_flux(&m->mag, 0.0, 0.0, &x[FS_X_PSI_D], &x[FS_X_PSI_Q]);
    if (m->cfg.phases == 5) x[FS_X_PSI_D3] = m->cfg.psi_f3;
    fs_pmsm_rest_flux(m, x);
}

void fs_pmsm_rest_flux(fs_pmsm *m, double *x)
{
    if (!m->harm) return;
    const double th = m->cfg.pole_pairs * x[FS_X_THETA_M];
    fs_harm_at g;
    harm_at(m, cos(th), sin(th), &g);
    x[FS_X_PSI_D] = m->p0_d + g.h_d;
    x[FS_X_PSI_Q] = m->p0_q + g.h_q;
}

void fs_pmsm_set_temperature(fs_pmsm *m, double *x, double r, double k)
{
    m->cfg.R_s = r * m->R_s0;
    if (m->harm) {
        /* the base model's currents f kept: phi' = flux'(f), psi = h + p0' + M^-1 (phi' - p0') */
        const double th = m->cfg.pole_pairs * x[FS_X_THETA_M];
        fs_harm_at g;
        harm_at(m, cos(th), sin(th), &g);
        double r_d, r_q, phi_d, phi_q, f_d, f_q;
        harm_phi(m, x, &g, &r_d, &r_q, &phi_d, &phi_q);
        fs_mag_current(&m->mag, phi_d, phi_q, &f_d, &f_q);
        fs_mag_set_magnet(&m->mag, k);
        fs_mag_flux(&m->mag, 0.0, 0.0, &m->p0_d, &m->p0_q);
        fs_mag_flux(&m->mag, f_d, f_q, &phi_d, &phi_q);
        const double m_d = 1.0 + g.a_d, m_q = 1.0 + g.a_q, det = m_d * m_q - g.a_x * g.a_x;
        const double e_d = phi_d - m->p0_d, e_q = phi_q - m->p0_q;
        x[FS_X_PSI_D] = g.h_d + m->p0_d + (m_q * e_d - g.a_x * e_q) / det;
        x[FS_X_PSI_Q] = g.h_q + m->p0_q + (m_d * e_q - g.a_x * e_d) / det;
        return;
    }
    double i_d, i_q;
    fs_mag_current(&m->mag, x[FS_X_PSI_D], x[FS_X_PSI_Q], &i_d, &i_q);
    fs_mag_set_magnet(&m->mag, k);
    fs_mag_flux(&m->mag, i_d, i_q, &x[FS_X_PSI_D], &x[FS_X_PSI_Q]);
    if (m->cfg.phases == 5) {
        const double psi_f3 = k * m->psi_f30;   /* the linear d3 axis: i_d3 kept */
        x[FS_X_PSI_D3] += psi_f3 - m->cfg.psi_f3;
        m->cfg.psi_f3 = psi_f3;
    }
}

/* The three- and five-phase paths, and the three-phase one with spatial
 * harmonics, each with or without the losses beyond the copper, are one
 * body specialised by constants `five`, `harm` and `losses`, so that the
 * three-phase one does no more work than it ever did. */
#if defined(__GNUC__)
#define FS_SPECIALISE static inline __attribute__((always_inline))
#else
#define FS_SPECIALISE static inline
#endif

static double friction(const fs_pmsm_config *c, double w)
{
    double f = c->B * w;
    if (c->T_coulomb > 0.0) {
        double s = w / c->w_coulomb;
        f += c->T_coulomb * (s > 1.0 ? 1.0 : (s < -1.0 ? -1.0 : s));
    }
    return f;
}

/* A brake of magnitude T_b (Karnopp): sliding, T_b against the motion; in
 * the stick band |w| < w_coulomb it takes up the net torque up to T_b, so a
 * held rotor stays held (a smooth T_b sat(w / w_c) would be as stiff as
 * T_b / (J w_c), far beyond the integration step for a rated-torque brake). */
static double brake_torque(const fs_pmsm_config *c, double w, double T_net, double T_b)
{
    T_b = fabs(T_b);
    if (w > c->w_coulomb) return T_b;
    if (w < -c->w_coulomb) return -T_b;
    return T_net > T_b ? T_b : (T_net < -T_b ? -T_b : T_net);
}

/* Torque the load machine applies against the motor (PI on speed). */
static double load_machine_torque(const fs_pmsm *m, const double *x, const fs_pmsm_input *in)
{
    return -(m->k_p_load * (in->w_load - x[FS_X_W_M]) + x[FS_X_LOAD_I]);
}

/* Third-harmonic currents of the linear d3-q3 model. */
FS_SPECIALISE void currents3(const fs_pmsm *m, const double *x, double *i_d3, double *i_q3)
{
    *i_d3 = (x[FS_X_PSI_D3] - m->cfg.psi_f3) * m->inv_L_d3;
    *i_q3 = x[FS_X_PSI_Q3] * m->inv_L_q3;
}

/* The iron loss's drag at a state (fs_losses.h). */
static double iron_drag(const fs_pmsm *m, const double *x)
{
    if (m->cfg.iron.P_ref == 0.0) return 0.0;   /* none: not even the flux's magnitude */
    return fs_iron_torque(&m->cfg.iron, m->cfg.pole_pairs, x[FS_X_W_M], hypot(x[FS_X_PSI_D], x[FS_X_PSI_Q]));
}

void fs_pmsm_iron(const fs_pmsm *m, const double *x, double *P_fe, double *T_fe)
{
    const double psi = hypot(x[FS_X_PSI_D], x[FS_X_PSI_Q]);
    *P_fe = m->cfg.iron.P_ref > 0.0 ? fs_iron_loss(&m->cfg.iron, m->cfg.pole_pairs * x[FS_X_W_M], psi) : 0.0;
    *T_fe = iron_drag(m, x);
}

/* T_fe: the iron loss's drag (with losses; else 0), which a brake holds against as it holds friction. */
/* i_at: the currents of x as fs_pmsm_current_dq gives them, or NULL (always NULL with harm: the
 * torque needs the energy's angle term, which harm_current computes with them). */
FS_SPECIALISE void outputs(fs_pmsm *m, const double *x, const fs_pmsm_input *in, double cs, double sn,
                           const int five, const int harm, const double T_fe, const fs_pmsm_at *i_at,
                           double *i_d, double *i_q, double *i_d3, double *i_q3, double *T_e, double *T_shaft)
{
    if (i_at) {
        *i_d = i_at->i_d;
        *i_q = i_at->i_q;
    } else if (harm) {
        double dW;
        harm_current(m, x, cs, sn, i_d, i_q, &dW);
        *T_e = 1.5 * m->cfg.pole_pairs * (x[FS_X_PSI_D] * *i_q - x[FS_X_PSI_Q] * *i_d - dW);
    } else {
        fs_mag_current_at(&m->mag, x[FS_X_PSI_D], x[FS_X_PSI_Q], i_d, i_q);
    }
    if (five) {
        currents3(m, x, i_d3, i_q3);
        *T_e = 2.5 * m->cfg.pole_pairs
               * (x[FS_X_PSI_D] * *i_q - x[FS_X_PSI_Q] * *i_d
                  + 3.0 * (x[FS_X_PSI_D3] * *i_q3 - x[FS_X_PSI_Q3] * *i_d3));
    } else if (!harm) {
        *T_e = 1.5 * m->cfg.pole_pairs * (x[FS_X_PSI_D] * *i_q - x[FS_X_PSI_Q] * *i_d);
    }
    double T = in->T_load;
    if (m->cfg.load_kind == FS_LOAD_SPEED_PI) T += load_machine_torque(m, x, in);
    if (m->cfg.load_kind == FS_LOAD_BRAKE) {
        const double w = x[FS_X_W_M];
        T = brake_torque(&m->cfg, w, *T_e - friction(&m->cfg, w) - T_fe, in->T_load);
    }
    *T_shaft = T;
}

void fs_pmsm_outputs_at(fs_pmsm *m, const double *x, const fs_pmsm_input *in, const fs_pmsm_at *a,
                        double *i_d, double *i_q, double *T_e, double *T_shaft)
{
    double i_d3, i_q3;
    const double T_fe = m->cfg.losses ? iron_drag(m, x) : 0.0;
    const fs_pmsm_at *i_at = a && a->reuse ? a : NULL;   /* reuse: no harmonics (fs_pmsm_at_state) */
    if (m->cfg.phases == 5) {
        outputs(m, x, in, 0.0, 0.0, 1, 0, T_fe, i_at, i_d, i_q, &i_d3, &i_q3, T_e, T_shaft);
    } else if (m->harm) {
        const double th = m->cfg.pole_pairs * x[FS_X_THETA_M];
        outputs(m, x, in, cos(th), sin(th), 0, 1, T_fe, NULL, i_d, i_q, &i_d3, &i_q3, T_e, T_shaft);
    } else {
        outputs(m, x, in, 0.0, 0.0, 0, 0, T_fe, i_at, i_d, i_q, &i_d3, &i_q3, T_e, T_shaft);
    }
}

void fs_pmsm_outputs(fs_pmsm *m, const double *x, const fs_pmsm_input *in,
                     double *i_d, double *i_q, double *T_e, double *T_shaft)
{
    fs_pmsm_outputs_at(m, x, in, NULL, i_d, i_q, T_e, T_shaft);
}

void fs_pmsm_current_dq(fs_pmsm *m, const double *x, double cs, double sn, double *i_d, double *i_q)
{
    if (m->harm) {
        harm_current(m, x, cs, sn, i_d, i_q, NULL);
    } else {
        fs_mag_current_at(&m->mag, x[FS_X_PSI_D], x[FS_X_PSI_Q], i_d, i_q);
    }
}

void fs_pmsm_currents3(const fs_pmsm *m, const double *x, double *i_d3, double *i_q3)
{
    if (m->cfg.phases == 5) currents3(m, x, i_d3, i_q3);
    else *i_d3 = *i_q3 = 0.0;
}

double fs_pmsm_energy(const fs_pmsm *m, const double *x)
{
    if (m->harm) {
        const double th = m->cfg.pole_pairs * x[FS_X_THETA_M];
        fs_harm_at g;
        harm_at(m, cos(th), sin(th), &g);
        double r_d, r_q, phi_d, phi_q;
        harm_phi(m, x, &g, &r_d, &r_q, &phi_d, &phi_q);
        const double W_cog = m->cfg.T_cog * g.c_cog / (1.5 * m->cfg.pole_pairs * m->cfg.cog_order);
        return 1.5 * (fs_mag_energy(&m->mag, phi_d, phi_q) + W_cog);
    }
    double W = fs_mag_energy(&m->mag, x[FS_X_PSI_D], x[FS_X_PSI_Q]);
    if (m->cfg.phases != 5) return 1.5 * W;
    double dd = x[FS_X_PSI_D3] - m->cfg.psi_f3, qq = x[FS_X_PSI_Q3];
    return 2.5 * (W + 0.5 * dd * dd / m->cfg.L_d3 + 0.5 * qq * qq / m->cfg.L_q3);
}

/* G = d(i_d, i_q)/d(psi_d, psi_q), the incremental inverse inductance, by
 * central differences of the magnetic model. */
static void incremental_inverse(fs_pmsm *m, double psi_d, double psi_q, double G[2][2])
{
    const double h = 1e-6 * (fabs(psi_d) + fabs(psi_q) + 1e-3);
    double ip_d, ip_q, im_d, im_q;
    fs_mag_current(&m->mag, psi_d + h, psi_q, &ip_d, &ip_q);
    fs_mag_current(&m->mag, psi_d - h, psi_q, &im_d, &im_q);
    G[0][0] = (ip_d - im_d) / (2.0 * h);
    G[1][0] = (ip_q - im_q) / (2.0 * h);
    fs_mag_current(&m->mag, psi_d, psi_q + h, &ip_d, &ip_q);
    fs_mag_current(&m->mag, psi_d, psi_q - h, &im_d, &im_q);
    G[0][1] = (ip_d - im_d) / (2.0 * h);
    G[1][1] = (ip_q - im_q) / (2.0 * h);
}

/* The right-hand side with the rotor angle's cosine and sine given. */
FS_SPECIALISE void deriv_cs(fs_pmsm *m, const double *x, const fs_pmsm_input *in, double cs,
                            double sn, const int five, const int harm, const int losses, const fs_pmsm_at *i_at,
                            double *dx)
{
    const fs_pmsm_config *c = &m->cfg;
    double i_d, i_q, i_d3 = 0.0, i_q3 = 0.0, T_e, T_shaft;
    const double T_fe = losses ? iron_drag(m, x) : 0.0;
    outputs(m, x, in, cs, sn, five, harm, T_fe, i_at, &i_d, &i_q, &i_d3, &i_q3, &T_e, &T_shaft);
    double w_m = x[FS_X_W_M];  /* SPEED_IDEAL: follows dw_load, reset each sample */
    double w_e = c->pole_pairs * w_m;
    double u_d = cs * in->u_alpha + sn * in->u_beta;
    double u_q = -sn * in->u_alpha + cs * in->u_beta;

    dx[FS_X_PSI_D] = u_d - c->R_s * i_d + w_e * x[FS_X_PSI_Q];
    dx[FS_X_PSI_Q] = u_q - c->R_s * i_q - w_e * x[FS_X_PSI_D];
    if (!five && !harm && in->open_phase) {   /* fs_sim refuses an open phase with harmonics */
        /* the open phase's terminal floats: a voltage lam along its axis n
         * keeps n.i at zero, d(n.i)/dt = -n.i / tau_open (Baumgarte) */
        const double n_a[3] = {1.0, -0.5, -0.5}, n_b[3] = {0.0, 0.8660254037844386, -0.8660254037844386};
        const int k = in->open_phase - 1;
        const double n_d = cs * n_a[k] + sn * n_b[k], n_q = -sn * n_a[k] + cs * n_b[k];
        double G[2][2];
        incremental_inverse(m, x[FS_X_PSI_D], x[FS_X_PSI_Q], G);
        const double g = n_d * i_d + n_q * i_q;
        const double Gn_d = G[0][0] * n_d + G[0][1] * n_q, Gn_q = G[1][0] * n_d + G[1][1] * n_q;
        const double nGa = n_d * (G[0][0] * dx[FS_X_PSI_D] + G[0][1] * dx[FS_X_PSI_Q])
                         + n_q * (G[1][0] * dx[FS_X_PSI_D] + G[1][1] * dx[FS_X_PSI_Q]);
        const double nGn = n_d * Gn_d + n_q * Gn_q;
        /* the frame turns: d(n_dq)/dt = w_e (n_q, -n_d) */
        const double lam = (-g / in->tau_open - w_e * (n_q * i_d - n_d * i_q) - nGa) / nGn;
        dx[FS_X_PSI_D] += lam * n_d;
        dx[FS_X_PSI_Q] += lam * n_q;
        u_d += lam * n_d;
        u_q += lam * n_q;
    }
    switch (c->load_kind) {
    case FS_LOAD_SPEED_IDEAL:
        dx[FS_X_W_M] = in->dw_load;
        dx[FS_X_LOAD_I] = 0.0;
        break;
    case FS_LOAD_SPEED_PI:
        dx[FS_X_W_M] = losses ? (T_e - T_shaft - friction(c, w_m) - T_fe) / (c->J + c->J_load)
                              : (T_e - T_shaft - friction(c, w_m)) / (c->J + c->J_load);
        dx[FS_X_LOAD_I] = m->k_i_load * (in->w_load - w_m);
        break;
    default:
        dx[FS_X_W_M] = losses ? (T_e - T_shaft - friction(c, w_m) - T_fe) / c->J
                              : (T_e - T_shaft - friction(c, w_m)) / c->J;
        dx[FS_X_LOAD_I] = 0.0;
    }
    dx[FS_X_THETA_M] = w_m;
    double c3 = 0.0, s3 = 0.0;
    if (five) {
        /* cos and sin of 3 theta_e: (cs + j sn)^3 */
        double c2 = cs * cs, s2 = sn * sn;
        c3 = cs * (c2 - 3.0 * s2);
        s3 = sn * (3.0 * c2 - s2);
        double u_d3 = c3 * in->u_x + s3 * in->u_y;
        double u_q3 = -s3 * in->u_x + c3 * in->u_y;
        double w_3 = 3.0 * w_e;
        dx[FS_X_PSI_D3] = u_d3 - c->R_s * i_d3 + w_3 * x[FS_X_PSI_Q3];
        dx[FS_X_PSI_Q3] = u_q3 - c->R_s * i_q3 - w_3 * x[FS_X_PSI_D3];
        dx[FS_X_E_IN] = 2.5 * (u_d * i_d + u_q * i_q + u_d3 * i_d3 + u_q3 * i_q3);
        dx[FS_X_E_CU] = 2.5 * c->R_s * (i_d * i_d + i_q * i_q + i_d3 * i_d3 + i_q3 * i_q3);
    } else {
        dx[FS_X_E_IN] = 1.5 * (u_d * i_d + u_q * i_q);
        dx[FS_X_E_CU] = 1.5 * c->R_s * (i_d * i_d + i_q * i_q);
    }
    dx[FS_X_E_AIRGAP] = T_e * w_m;
    dx[FS_X_UD_INT] = u_d;
    dx[FS_X_UQ_INT] = u_q;
    if (losses) {
        if (!five) dx[FS_X_PSI_D3] = dx[FS_X_PSI_Q3] = 0.0;   /* not a three-phase machine's: held */
        dx[FS_X_E_FE] = T_fe * w_m;
        dx[FS_X_E_MECH] = friction(c, w_m) * w_m;
        /* an ideal speed load takes whatever the shaft gives beyond the speed's own change */
        dx[FS_X_E_SHAFT] = (c->load_kind == FS_LOAD_SPEED_IDEAL ? T_e - friction(c, w_m) - T_fe - c->J * in->dw_load
                                                                : T_shaft) * w_m;
        dx[FS_X_I_A_INT] = cs * i_d - sn * i_q;
        dx[FS_X_I_B_INT] = sn * i_d + cs * i_q;
        dx[FS_X_I_X_INT] = five ? c3 * i_d3 - s3 * i_q3 : 0.0;
        dx[FS_X_I_Y_INT] = five ? s3 * i_d3 + c3 * i_q3 : 0.0;
    }
}

void fs_pmsm_deriv(fs_pmsm *m, const double *x, const fs_pmsm_input *in, double *dx)
{
    double th = m->cfg.pole_pairs * x[FS_X_THETA_M];
    const double cs = cos(th), sn = sin(th);
    const int five = m->cfg.phases == 5;
    if (m->cfg.losses) {
        if (five) deriv_cs(m, x, in, cs, sn, 1, 0, 1, NULL, dx);
        else if (m->harm) deriv_cs(m, x, in, cs, sn, 0, 1, 1, NULL, dx);
        else deriv_cs(m, x, in, cs, sn, 0, 0, 1, NULL, dx);
    } else {
        if (five) deriv_cs(m, x, in, cs, sn, 1, 0, 0, NULL, dx);
        else if (m->harm) deriv_cs(m, x, in, cs, sn, 0, 1, 0, NULL, dx);
        else deriv_cs(m, x, in, cs, sn, 0, 0, 0, NULL, dx);
    }
}

/* The right-hand side at a stage whose angle is the step's start angle
 * (cos c0, sin s0) plus a small d: cos and sin of d by their Taylor series,
 * within 1e-10 for |d| <= 0.15 rad (a fraction of the cost of cos and sin),
 * and by the library otherwise. */
FS_SPECIALISE void deriv_stage(fs_pmsm *m, const double *x0, const double *y,
                               const fs_pmsm_input *in, double c0, double s0, const int five,
                               const int harm, const int losses, double *dx)
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
    deriv_cs(m, y, in, c0 * cd - s0 * sd, s0 * cd + c0 * sd, five, harm, losses, NULL, dx);
}

/* A stage's state y = x + c k, formed only where the right-hand side reads
 * it: the fluxes, the speed, the angle and the load machine's integral
 * (FS_X_PSI_D .. FS_X_LOAD_I), and a five-phase machine's d3-q3 fluxes. No
 * derivative reads a meter (the energies, UD_INT and UQ_INT, the loss
 * meters, the currents' integrals), so their stage values, formed before,
 * were never used; every state still takes the step's sum. */
FS_SPECIALISE void stage_state(const double *x, double c, const double *k, const int five, double *y)
{
    for (int n = FS_X_PSI_D; n <= FS_X_LOAD_I; ++n) {
        y[n] = x[n] + c * k[n];
    }
    if (five != 0) {
        y[FS_X_PSI_D3] = x[FS_X_PSI_D3] + c * k[FS_X_PSI_D3];
        y[FS_X_PSI_Q3] = x[FS_X_PSI_Q3] + c * k[FS_X_PSI_Q3];
    }
}

/* RK4 over the first NX states (FS_X_N3: three phases, FS_X_N5: five;
 * FS_X_N with the loss meters); harm: the three-phase machine with its
 * spatial harmonics. */
FS_SPECIALISE void rk4(fs_pmsm *m, double *x, const fs_pmsm_input *in, double h, const fs_pmsm_at *a,
                       const int five, const int harm, const int losses)
{
    enum { NX = FS_X_N };
    const int nx = losses ? FS_X_N : (five ? FS_X_N5 : FS_X_N3);
    double k1[NX], k2[NX], k3[NX], k4[NX], y[NX];
    double c0, s0;
    if (a) {
        c0 = a->cs;
        s0 = a->sn;
    } else {
        double th = m->cfg.pole_pairs * x[FS_X_THETA_M];
        c0 = cos(th);
        s0 = sin(th);
    }
    deriv_cs(m, x, in, c0, s0, five, harm, losses, !harm && a && a->reuse ? a : NULL, k1);
    stage_state(x, 0.5 * h, k1, five, y);
    deriv_stage(m, x, y, in, c0, s0, five, harm, losses, k2);
    stage_state(x, 0.5 * h, k2, five, y);
    deriv_stage(m, x, y, in, c0, s0, five, harm, losses, k3);
    stage_state(x, h, k3, five, y);
    deriv_stage(m, x, y, in, c0, s0, five, harm, losses, k4);
    for (int n = 0; n < nx; ++n) x[n] += h / 6.0 * (k1[n] + 2.0 * k2[n] + 2.0 * k3[n] + k4[n]);
}

void fs_pmsm_rk4_at(fs_pmsm *m, double *x, const fs_pmsm_input *in, double h, const fs_pmsm_at *a)
{
    if (m->cfg.losses) {
        if (m->cfg.phases == 5) rk4(m, x, in, h, a, 1, 0, 1);
        else if (m->harm) rk4(m, x, in, h, a, 0, 1, 1);
        else rk4(m, x, in, h, a, 0, 0, 1);
    } else {
        if (m->cfg.phases == 5) rk4(m, x, in, h, a, 1, 0, 0);
        else if (m->harm) rk4(m, x, in, h, a, 0, 1, 0);
        else rk4(m, x, in, h, a, 0, 0, 0);
    }
}

void fs_pmsm_rk4(fs_pmsm *m, double *x, const fs_pmsm_input *in, double h)
{
    fs_pmsm_rk4_at(m, x, in, h, NULL);
}

void fs_pmsm_at_state(fs_pmsm *m, const double *x, fs_pmsm_at *a)
{
    const double th = m->cfg.pole_pairs * x[FS_X_THETA_M];
    a->cs = cos(th);
    a->sn = sin(th);
    fs_pmsm_current_dq(m, x, a->cs, a->sn, &a->i_d, &a->i_q);
    a->reuse = !m->harm && m->mag.cfg.kind != FS_MAG_FLUXMAP;
}
