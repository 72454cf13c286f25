#include "fs_magnetic.h"
#include "fs_magnetic_inline.h"

#include <math.h>

static double powabs(double x, double e)
{
    double a = fabs(x);
    if (e == 0.0) return 1.0;
    return a > 0.0 ? pow(a, e) : 0.0;
}

/* |x|^n for an integer n >= 0 by binary powering (0^0 = 1, as powabs). */
static inline double powi(double a, int n)
{
    double r = 1.0;
    for (;;) {
        if (n & 1) r *= a;
        n >>= 1;
        if (!n) return r;
        a *= a;
    }
}

/* |x|^e: by multiplication when fs_mag_init found e a small integer n. */
static inline double powabs_n(double x, int n, double e)
{
    return n >= 0 ? powi(fabs(x), n) : powabs(x, e);
}

/* e as an integer 0..FS_MAG_POW_NMAX, or -1. */
static int small_int(double e)
{
    return (e >= 0.0 && e <= FS_MAG_POW_NMAX && e == floor(e)) ? (int)e : -1;
}

static void algebraic_current(const fs_mag *m, double psi_d, double psi_q, double *i_d, double *i_q)
{
    const fs_mag_config *c = &m->cfg;
    double gd = m->a_d0, gq = m->a_q0;
    if (c->a_dd != 0.0) gd += c->a_dd * powabs_n(psi_d, m->n_S, c->S);
    if (c->a_qq != 0.0) gq += c->a_qq * powabs_n(psi_q, m->n_T, c->T);
    if (c->a_dq != 0.0) {
        double cross = powabs_n(psi_d, m->n_U, c->U) * powabs_n(psi_q, m->n_V, c->V);
        gd += m->c_d * cross * psi_q * psi_q;
        gq += m->c_q * cross * psi_d * psi_d;
    }
    *i_d = gd * psi_d - m->i_f;
    *i_q = gq * psi_q;
}

/* The cell of grid coordinate x on n points: floor(x) held to [0, n - 2],
 * compared as a double first, so that a coordinate far off the grid or NaN
 * (Newton's iterate on a diverged state) is never cast out of int's range. */
static int map_cell(double x, int n)
{
    if (!(x >= 1.0)) return 0;
    if (x >= n - 2) return n - 2;
    return (int)x;
}

/* Bilinear interpolation of the map and its Jacobian d(psi)/d(i). */
static void map_eval(const fs_mag_config *c, double i_d, double i_q, double psi[2], double jac[4])
{
    double x = (i_d - c->map_i_d0) / c->map_di_d;
    double y = (i_q - c->map_i_q0) / c->map_di_q;
    int k = map_cell(x, c->map_n_d), l = map_cell(y, c->map_n_q);
    double s = x - k, t = y - l;  /* extrapolates linearly outside the grid */
    const double *tabs[2] = {c->map_psi_d, c->map_psi_q};
    for (int n = 0; n < 2; ++n) {
        const double *p = tabs[n];
        double p00 = p[k * c->map_n_q + l], p01 = p[k * c->map_n_q + l + 1];
        double p10 = p[(k + 1) * c->map_n_q + l], p11 = p[(k + 1) * c->map_n_q + l + 1];
        psi[n] = (1 - s) * (1 - t) * p00 + (1 - s) * t * p01 + s * (1 - t) * p10 + s * t * p11;
        jac[2 * n + 0] = ((1 - t) * (p10 - p00) + t * (p11 - p01)) / c->map_di_d;
        jac[2 * n + 1] = ((1 - s) * (p01 - p00) + s * (p11 - p10)) / c->map_di_q;
    }
}

static void map_current(fs_mag *m, double psi_d, double psi_q, double *i_d, double *i_q)
{
    double id = m->hint_d, iq = m->hint_q;
    for (int it = 0; it < 20; ++it) {
        double psi[2], J[4];
        map_eval(&m->cfg, id, iq, psi, J);
        double rd = psi_d - psi[0], rq = psi_q - psi[1];
        double det = J[0] * J[3] - J[1] * J[2];
        if (det == 0.0 || !isfinite(det)) break;
        double dd = (J[3] * rd - J[1] * rq) / det;
        double dq = (-J[2] * rd + J[0] * rq) / det;
        id += dd;
        iq += dq;
        if (fabs(dd) + fabs(dq) < 1e-12 * (1.0 + fabs(id) + fabs(iq))) break;
    }
    m->hint_d = id;
    m->hint_q = iq;
    *i_d = id;
    *i_q = iq;
}

/* x >= 0 (or > 0) and finite */
static int nonneg(double x) { return x >= 0.0 && isfinite(x); }
static int pos(double x) { return x > 0.0 && isfinite(x); }

fs_status fs_mag_init(fs_mag *m, const fs_mag_config *cfg)
{
    if (!m || !cfg) return FS_ERR_NULL;
    m->cfg = *cfg;
    m->i_f = 0.0;
    m->hint_d = m->hint_q = 0.0;
    m->psi_f0 = cfg->psi_f;
    m->i_f0 = 0.0;
    m->a_d0 = m->a_q0 = m->c_d = m->c_q = 0.0;
    m->n_S = m->n_T = m->n_U = m->n_V = -1;
    if (cfg->kind != FS_MAG_LINEAR && cfg->kind != FS_MAG_ALGEBRAIC && cfg->kind != FS_MAG_FLUXMAP) return FS_ERR_MODE;
    /* a flux map does not read them: finite is enough there */
    const int map = cfg->kind == FS_MAG_FLUXMAP;
    if (map ? !isfinite(cfg->L_d) : !pos(cfg->L_d)) return FS_ERR_LD;
    if (map ? !isfinite(cfg->L_q) : !pos(cfg->L_q)) return FS_ERR_LQ;
    if (map ? !isfinite(cfg->psi_f) : !nonneg(cfg->psi_f)) return FS_ERR_PSI_F;
    switch (cfg->kind) {
    case FS_MAG_LINEAR:
        return FS_OK;
    case FS_MAG_ALGEBRAIC: {
        if (!nonneg(cfg->a_dd) || !nonneg(cfg->a_qq) || !nonneg(cfg->a_dq)) return FS_ERR_PARAM;
        if (!nonneg(cfg->S) || !nonneg(cfg->T) || !nonneg(cfg->U) || !nonneg(cfg->V)) return FS_ERR_PARAM;
        m->a_d0 = 1.0 / cfg->L_d;
        m->a_q0 = 1.0 / cfg->L_q;
        m->c_d = cfg->a_dq / (cfg->V + 2.0);
        m->c_q = cfg->a_dq / (cfg->U + 2.0);
        m->n_S = small_int(cfg->S);
        m->n_T = small_int(cfg->T);
        m->n_U = small_int(cfg->U);
        m->n_V = small_int(cfg->V);
        double id, iq;
        algebraic_current(m, cfg->psi_f, 0.0, &id, &iq);
        m->i_f = m->i_f0 = id;  /* i_d(psi_f, 0) with i_f = 0: makes psi_d = psi_f at zero current */
        return isfinite(id) ? FS_OK : FS_ERR_PARAM;
    }
    default:   /* FS_MAG_FLUXMAP */
        if (cfg->map_n_d < 2 || cfg->map_n_q < 2 || !pos(cfg->map_di_d) || !pos(cfg->map_di_q)
            || !isfinite(cfg->map_i_d0) || !isfinite(cfg->map_i_q0))
            return FS_ERR_PARAM;
        if (!cfg->map_psi_d || !cfg->map_psi_q) return FS_ERR_NULL;
        for (long k = 0; k < (long)cfg->map_n_d * cfg->map_n_q; ++k)
            if (!isfinite(cfg->map_psi_d[k]) || !isfinite(cfg->map_psi_q[k])) return FS_ERR_PARAM;
        return FS_OK;
    }
}

void fs_mag_set_magnet(fs_mag *m, double k)
{
    if (m->cfg.kind == FS_MAG_FLUXMAP) return;
    m->cfg.psi_f = k * m->psi_f0;   /* LINEAR's magnet; ALGEBRAIC: Newton's start in fs_mag_flux */
    m->i_f = k * m->i_f0;
}

void fs_mag_current(fs_mag *m, double psi_d, double psi_q, double *i_d, double *i_q)
{
    switch (m->cfg.kind) {
    case FS_MAG_ALGEBRAIC:
        algebraic_current(m, psi_d, psi_q, i_d, i_q);
        return;
    case FS_MAG_FLUXMAP:
        map_current(m, psi_d, psi_q, i_d, i_q);
        return;
    default:
        fs_mag_current_linear(m, psi_d, psi_q, i_d, i_q);
    }
}

void fs_mag_flux(fs_mag *m, double i_d, double i_q, double *psi_d, double *psi_q)
{
    if (m->cfg.kind == FS_MAG_FLUXMAP) {
        double psi[2], J[4];
        map_eval(&m->cfg, i_d, i_q, psi, J);
        *psi_d = psi[0];
        *psi_q = psi[1];
        m->hint_d = i_d;
        m->hint_q = i_q;
        return;
    }
    /* Newton on i(psi) from the unsaturated guess (exact for LINEAR). */
    double pd = m->cfg.psi_f + m->cfg.L_d * i_d, pq = m->cfg.L_q * i_q;
    for (int it = 0; it < 50; ++it) {
        double id, iq, id1, iq1, id2, iq2, h = 1e-7;
        fs_mag_current(m, pd, pq, &id, &iq);
        double rd = i_d - id, rq = i_q - iq;
        if (fabs(rd) + fabs(rq) < 1e-12 * (1.0 + fabs(i_d) + fabs(i_q))) break;
        fs_mag_current(m, pd + h, pq, &id1, &iq1);
        fs_mag_current(m, pd, pq + h, &id2, &iq2);
        double a = (id1 - id) / h, b = (id2 - id) / h, c = (iq1 - iq) / h, d = (iq2 - iq) / h;
        double det = a * d - b * c;
        if (det == 0.0 || !isfinite(det)) break;
        pd += (d * rd - b * rq) / det;
        pq += (-c * rd + a * rq) / det;
    }
    *psi_d = pd;
    *psi_q = pq;
}

void fs_mag_flux_n(fs_mag *m, const double *i_d, const double *i_q, int n, double *psi_d, double *psi_q)
{
    for (int k = 0; k < n; ++k) fs_mag_flux(m, i_d[k], i_q[k], &psi_d[k], &psi_q[k]);
}

double fs_mag_energy(const fs_mag *m, double psi_d, double psi_q)
{
    const fs_mag_config *c = &m->cfg;
    switch (c->kind) {
    case FS_MAG_LINEAR: {
        double dpd = psi_d - c->psi_f;
        return 0.5 * dpd * dpd / c->L_d + 0.5 * psi_q * psi_q / c->L_q;
    }
    case FS_MAG_ALGEBRAIC: {
        /* |x|^(n+2) = |x|^n x^2 on the integer path */
        double pd2 = psi_d * psi_d, pq2 = psi_q * psi_q;
        double wS = m->n_S >= 0 ? powi(fabs(psi_d), m->n_S) * pd2 : powabs(psi_d, c->S + 2.0);
        double wT = m->n_T >= 0 ? powi(fabs(psi_q), m->n_T) * pq2 : powabs(psi_q, c->T + 2.0);
        double wU = m->n_U >= 0 ? powi(fabs(psi_d), m->n_U) * pd2 : powabs(psi_d, c->U + 2.0);
        double wV = m->n_V >= 0 ? powi(fabs(psi_q), m->n_V) * pq2 : powabs(psi_q, c->V + 2.0);
        return 0.5 * pd2 / c->L_d + c->a_dd / (c->S + 2.0) * wS
             + 0.5 * pq2 / c->L_q + c->a_qq / (c->T + 2.0) * wT
             + c->a_dq / ((c->U + 2.0) * (c->V + 2.0)) * wU * wV
             - m->i_f * psi_d;
    }
    default:
        return NAN;
    }
}
