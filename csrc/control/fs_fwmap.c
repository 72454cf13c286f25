#include "fs_fwmap.h"
#include "fs_math.h"

/* the flux limit's angle is marched in steps of pi / FWMAP_NS from the d axis */
#define FWMAP_NS 256
/* the least flux is searched on the d axis in steps of i_max / FWMAP_NLF */
#define FWMAP_NLF 64

static float fwmap_torque(const fs_fwmap_config *c, fs_dq i, const fs_fluxmap_point *p)
{
    return c->k_T * (p->psi.d * i.q - p->psi.q * i.d);
}

/* The current whose flux is psi_t, by Newton's method on the map's
 * incremental inductance matrix (cross-saturation included) from the guess
 * *i (the last solution: the targets move a little at a time), each step
 * held within a tenth of i_max. Returns its torque; false in *ok when it
 * does not converge to tol (a map folded back on itself). */
static FS_COLD float fwmap_inverse(const fs_fwmap_config *c, float tol, fs_dq psi_t, fs_dq *i, bool *ok)
{
    const float step_max = 0.1f * c->i_max;
    for (int n = 0; n < 60; ++n) {
        const fs_fluxmap_point p = fs_fluxmap_eval(c->map, *i);
        const float e_d = psi_t.d - p.psi.d, e_q = psi_t.q - p.psi.q;
        if (fabsf(e_d) <= tol && fabsf(e_q) <= tol) {
            *ok = true;
            return fwmap_torque(c, *i, &p);
        }
        const float det = p.L_dd * p.L_qq - p.L_dq * p.L_qd;
        float dd = (p.L_qq * e_d - p.L_dq * e_q) / det, dq = (p.L_dd * e_q - p.L_qd * e_d) / det;
        if (!(det > 0.0f)) {   /* the matrix folded: along each axis alone */
            dd = e_d / p.L_dd;
            dq = e_q / p.L_qq;
        }
        i->d += fs_clamp_sym(dd, step_max);
        i->q += fs_clamp_sym(dq, step_max);
    }
    *ok = false;
    return 0.0f;
}

/* The torque and the current's magnitude at angle d of the flux limit
 * psi_lim (the current in *i, from its guess there). */
static FS_COLD float fwmap_at(const fs_fwmap_config *c, float tol, float psi_lim, float d, fs_dq *i, float *I, bool *ok)
{
    const float _Complex e = fs_cis(d);   /* the drive's own trigonometry: no libm sinf/cosf in the image */
    const float T = fwmap_inverse(c, tol, (fs_dq){psi_lim * fs_cre(e), psi_lim * fs_cim(e)}, i, ok);
    *I = sqrtf(i->d * i->d + i->q * i->q);
    return T;
}

/* One row, at the flux limit psi_lim: T_max and the currents at NT
 * torques (fs_fwmap.h). A march along the flux limit finds its most torque
 * within the current limit: at a sample (MTPV, the flat maximum along it)
 * or where the current limit cuts it (the crossing interpolated). Below
 * that angle the torque falls to a minimum (near the d axis the flux
 * limit's currents have a positive d current and brake); a torque below
 * T_max is found by bisection of the angle on the rising arc between. */
static FS_COLD fs_status fwmap_row(fs_fwmap *f, const fs_fwmap_config *c, fs_mtpa *mtpa, int k, float psi_lim, float i_lf)
{
    const float tol = 1e-6f * f->psi_mtpa;
    const float dd = FS_PI / (float)FWMAP_NS;
    fs_dq i = {0.0f, 0.0f}, i_prev = i;
    bool ok = true, in_prev = false;
    float T_prev = 0.0f, I_prev = 0.0f, d_end = 0.0f, T_end = 0.0f;
    fs_dq i_end = i;
    fs_dq i_good = i;
    for (int m = 0; m < FWMAP_NS; ++m) {
        const float d = (float)m * dd;
        float I;
        const float T = fwmap_at(c, tol, psi_lim, d, &i, &I, &ok);
        if (!ok) {   /* no current has this flux (the map folds here under cross-saturation): not a point of the limit */
            i = i_good;
            in_prev = false;
            continue;
        }
        i_good = i;
        const bool in = I <= c->i_max;
        if (in && T > T_end) {
            d_end = d;
            i_end = i;
            T_end = T;
        }
        if (m > 0 && in != in_prev) {   /* the current limit cuts the flux limit between the last angle and this */
            const float s = (c->i_max - I_prev) / (I - I_prev);
            const float T_x = T_prev + s * (T - T_prev);
            if (T_x > T_end) {
                d_end = d - dd + s * dd;
                i_end = (fs_dq){i_prev.d + s * (i.d - i_prev.d), i_prev.q + s * (i.q - i_prev.q)};
                T_end = T_x;
            }
        }
        T_prev = T;
        I_prev = I;
        i_prev = i;
        in_prev = in;
    }
    /* the rising arc's start: down from d_end while the torque falls and the current is within the limit */
    float d_lo = d_end, T_lo = T_end;
    fs_dq il = i_end;
    while (d_lo - dd >= 0.0f) {
        fs_dq in_i = il;
        float I;
        const float T = fwmap_at(c, tol, psi_lim, d_lo - dd, &in_i, &I, &ok);
        if (!ok) { return FS_ERR_PARAM; }
        if (!(T < T_lo) || I > c->i_max) { break; }
        d_lo -= dd;
        T_lo = T;
        il = in_i;
    }
    f->T_max[k] = fs_maxf(T_end, 0.0f);
    if (!(T_end > 0.0f)) {   /* beyond the top speed: no torque within both limits; the least flux there is */
        for (int j = 0; j < FS_FWMAP_NT; ++j) {
            f->i_d[k * FS_FWMAP_NT + j] = i_lf;
            f->i_q[k * FS_FWMAP_NT + j] = 0.0f;
        }
        return FS_OK;
    }
    for (int j = 0; j < FS_FWMAP_NT; ++j) {
        const int n = k * FS_FWMAP_NT + j;
        const float T_j = f->T_max[k] * (float)j / (float)(FS_FWMAP_NT - 1);
        fs_dq a = fs_mtpa_step(mtpa, T_j);
        const fs_fluxmap_point p = fs_fluxmap_eval(c->map, a);
        if (sqrtf(p.psi.d * p.psi.d + p.psi.q * p.psi.q) <= psi_lim) {   /* MTPA within the flux limit */
            f->i_d[n] = a.d;
            f->i_q[n] = a.q;
            continue;
        }
        if (j == FS_FWMAP_NT - 1) {
            f->i_d[n] = i_end.d;
            f->i_q[n] = i_end.q;
            continue;
        }
        /* T rises along the flux limit on [d_lo, d_end]: bisection for T_j */
        float lo = d_lo, hi = d_end;
        fs_dq ib = i_end;
        for (int b = 0; b < 24; ++b) {
            const float mid = 0.5f * (lo + hi);
            float I;
            const float T = fwmap_at(c, tol, psi_lim, mid, &ib, &I, &ok);
            if (!ok) { return FS_ERR_PARAM; }
            if (T < T_j) { lo = mid; } else { hi = mid; }
        }
        f->i_d[n] = ib.d;
        f->i_q[n] = fs_maxf(ib.q, 0.0f);
    }
    return FS_OK;
}

FS_COLD fs_status fs_fwmap_init(fs_fwmap *f, const fs_fwmap_config *cfg, fs_mtpa *mtpa)
{
    if (!f || !cfg || !cfg->map || !mtpa) { return FS_ERR_NULL; }
    if (!fs_pos(cfg->i_max)) { return FS_ERR_I_MAX; }
    if (!fs_pos(cfg->k_T)) { return FS_ERR_PARAM; }
    if (!fs_pos(cfg->Ts) || !fs_pos(cfg->bw_current)) { return FS_ERR_BANDWIDTH; }
    f->k_trim = FS_FWMAP_TRIM_PER_BW * cfg->bw_current * cfg->Ts;
    fs_fwmap_reset(f);
    const fs_dq i_top = fs_mtpa_step(mtpa, INFINITY);   /* MTPA at i_max */
    const fs_fluxmap_point p = fs_fluxmap_eval(cfg->map, i_top);
    f->psi_mtpa = sqrtf(p.psi.d * p.psi.d + p.psi.q * p.psi.q);
    if (!fs_pos(f->psi_mtpa)) { return FS_ERR_PARAM; }
    /* the least flux within the current limit, on the d axis (fs_fwmap.h): the top speed's ratio */
    float i_lf = 0.0f, psi_min = f->psi_mtpa;
    for (int n = 0; n <= FWMAP_NLF; ++n) {
        const float i_d = -cfg->i_max * (float)n / (float)FWMAP_NLF;
        const float psi = fabsf(fs_fluxmap_eval(cfg->map, (fs_dq){i_d, 0.0f}).psi.d);
        if (psi < psi_min) {
            psi_min = psi;
            i_lf = i_d;
        }
    }
    const float x_top = psi_min > 0.0f ? f->psi_mtpa / psi_min : FS_FWMAP_X_MAX;
    const float x_n = fs_maxf(fs_minf(x_top, FS_FWMAP_X_MAX), 1.001f) - 1.0f;
    f->inv_dx = 1.0f / x_n;
    for (int k = 0; k < FS_FWMAP_NX; ++k) {
        const float s = (float)k / (float)(FS_FWMAP_NX - 1);
        const fs_status st = fwmap_row(f, cfg, mtpa, k, f->psi_mtpa / (1.0f + x_n * s * s), i_lf);
        if (st != FS_OK) { return st; }
    }
    return FS_OK;
}

void fs_fwmap_reset(fs_fwmap *f) { f->trim = 0.0f; }

float fs_fwmap_ratio(const fs_fwmap *f, float u_lim, float w_e)
{
    return u_lim > 0.0f ? (1.0f + f->trim) * f->psi_mtpa * fabsf(w_e) / u_lim : FS_FWMAP_X_MAX;
}

void fs_fwmap_trim(fs_fwmap *f, float u, float u_plan, float psi, float x)
{
    /* down to the base speed's x = 1 (x / (1 + trim) is the ratio without it), and at most by half */
    const float lo = fs_maxf((1.0f + f->trim) / x - 1.0f, -0.5f);
    const float e = (u - u_plan) / u_plan;
    /* below the plan with the current's flux inside the flux limit (header): the trim holds */
    const bool inside = (e < 0.0f) && (psi < (((1.0f - FS_FWMAP_INSIDE) * f->psi_mtpa) / x));
    if (!inside) {
        const float k = (e > 0.0f) ? f->k_trim : (FS_FWMAP_TRIM_APPROACH * f->k_trim);   /* away from the limit fast, towards it slowly */
        f->trim = fs_clampf(f->trim + (k * e), fs_minf(lo, 0.0f), 1.0f);
    }
}

fs_dq fs_fwmap_step(const fs_fwmap *f, float x, float T_ref, float *T_real)
{
    /* rows at x_k = 1 + (x_end - 1) (k / (NX - 1))^2: dense near base speed, where the flux limit moves fastest */
    const float u = fs_minf(sqrtf(fs_maxf(x - 1.0f, 0.0f) * f->inv_dx), 1.0f) * (float)(FS_FWMAP_NX - 1);   /* held beyond X_MAX */
    const int k = (int)fs_minf(u, (float)(FS_FWMAP_NX - 2));
    const float a = u - (float)k;
    const float T_max = f->T_max[k] + a * (f->T_max[k + 1] - f->T_max[k]);
    const float T = fs_minf(fabsf(T_ref), T_max);
    *T_real = T_ref < 0.0f ? -T : T;
    fs_dq i;
    /* beyond the top speed (T_max 0) the rows hold the least flux */
    const float t = T_max > 0.0f ? T / T_max * (float)(FS_FWMAP_NT - 1) : 0.0f;
    const int j = (int)fs_minf(t, (float)(FS_FWMAP_NT - 2));
    const float b = t - (float)j;
    const int n = k * FS_FWMAP_NT + j;
    const float *D = f->i_d + n, *Q = f->i_q + n;
    const float d0 = D[0] + b * (D[1] - D[0]), d1 = D[FS_FWMAP_NT] + b * (D[FS_FWMAP_NT + 1] - D[FS_FWMAP_NT]);
    const float q0 = Q[0] + b * (Q[1] - Q[0]), q1 = Q[FS_FWMAP_NT] + b * (Q[FS_FWMAP_NT + 1] - Q[FS_FWMAP_NT]);
    i.d = d0 + a * (d1 - d0);
    i.q = q0 + a * (q1 - q0);
    if (T_ref < 0.0f) { i.q = -i.q; }
    return i;
}
