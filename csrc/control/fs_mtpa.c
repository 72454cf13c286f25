#include "fs_mtpa.h"
#include "fs_math.h"

#include <stddef.h>

static float mtpa_id(const fs_mtpa_config *c, float I)
{
    float dL = c->L_q - c->L_d;
    if (dL <= 1e-9f * c->L_q) return 0.0f;
    return (c->psi_f - sqrtf(c->psi_f * c->psi_f + 8.0f * dL * dL * I * I)) / (4.0f * dL);
}

/* Torque per (flux x current): (phases / 2) p. */
static float mtpa_k(const fs_mtpa_config *c) { return 0.5f * (float)c->phases * (float)c->pole_pairs; }

/* A given table: FS_MTPA_N finite points, the current magnitude at each
 * the table's own (i_max k / (N - 1), to 0.1 %), the torque 0 at first and
 * rising. */
static fs_status mtpa_copy(fs_mtpa *m, const fs_mtpa_table *t)
{
    if (t->n != FS_MTPA_N) return FS_ERR_PARAM;
    for (int k = 0; k < FS_MTPA_N; ++k) {
        float I = m->cfg.i_max * (float)k / (float)(FS_MTPA_N - 1);
        if (!fs_fin(t->T[k]) || !fs_fin(t->i_d[k]) || !(t->i_q[k] >= 0.0f) || !fs_fin(t->i_q[k])) return FS_ERR_PARAM;
        if (!(fabsf(hypotf(t->i_d[k], t->i_q[k]) - I) <= 1e-3f * m->cfg.i_max)) return FS_ERR_PARAM;
        if (k == 0 ? !(t->T[0] == 0.0f) : !(t->T[k] > t->T[k - 1])) return FS_ERR_PARAM;
        m->T[k] = t->T[k];
        m->i_d[k] = t->i_d[k];
        m->i_q[k] = t->i_q[k];
    }
    return FS_OK;
}

fs_status fs_mtpa_init(fs_mtpa *m, const fs_mtpa_config *cfg)
{
    if (!m || !cfg) return FS_ERR_NULL;
    if (!fs_pos(cfg->L_d)) return FS_ERR_LD;
    if (!(cfg->L_q >= cfg->L_d) || !fs_fin(cfg->L_q)) return FS_ERR_LQ;  /* MTPA here assumes L_q >= L_d */
    if (!fs_nonneg(cfg->psi_f)) return FS_ERR_PSI_F;
    if (cfg->pole_pairs < 1) return FS_ERR_POLE_PAIRS;
    if (cfg->phases != 3 && cfg->phases != 5) return FS_ERR_PARAM;
    if (!fs_pos(cfg->i_max)) return FS_ERR_I_MAX;
    m->cfg = *cfg;
    m->cfg.table = NULL;
    m->tabulated = cfg->table != NULL;
    m->k_T = mtpa_k(cfg);
    m->seg = 0;
    m->dL = cfg->L_q - cfg->L_d;
    m->dL2 = 2.0f * m->dL;
    m->dL4 = 4.0f * m->dL * m->dL;
    m->psi2 = cfg->psi_f * cfg->psi_f;
    m->salient = m->dL > 1e-9f * cfg->L_q;
    if (cfg->table) return mtpa_copy(m, cfg->table);
    for (int k = 0; k < FS_MTPA_N; ++k) {
        float I = cfg->i_max * (float)k / (float)(FS_MTPA_N - 1);
        float id = mtpa_id(cfg, I);
        float iq = sqrtf(fs_maxf(I * I - id * id, 0.0f));
        m->i_d[k] = id;
        m->i_q[k] = iq;
        m->T[k] = mtpa_k(cfg) * (cfg->psi_f + (cfg->L_d - cfg->L_q) * id) * iq;
        /* the torque must rise, finite: not without torque (psi_f = 0 and
         * L_q = L_d), nor beyond the float range */
        if (k > 0 && !(m->T[k] > m->T[k - 1] && m->T[k] < INFINITY)) return FS_ERR_PARAM;
    }
    return FS_OK;
}

/* The MTPA locus as i_d(i_q): psi_f i_d + (L_d - L_q)(i_d^2 - i_q^2) = 0,
 * written without the cancellation of psi_f - sqrt(...) at small currents
 * (i_d = -i_q without a magnet). */
static float mtpa_locus_id(const fs_mtpa *m, float iq)
{
    if (m->cfg.psi_f <= 0.0f) return -iq;
    if (!m->salient) return 0.0f;
    return -m->dL2 * iq * iq / (m->cfg.psi_f + sqrtf(m->psi2 + m->dL4 * iq * iq));
}

/* The torque on the locus at (id, iq) and its slope d T / d i_q (the
 * second pass of a step needs i_d alone: apart, it skips this). */
static float mtpa_locus_torque(const fs_mtpa *m, float iq, float id, float *dT)
{
    const float did = m->cfg.psi_f <= 0.0f ? -1.0f : (m->salient ? m->dL2 * iq / (m->dL2 * id - m->cfg.psi_f) : 0.0f);
    const float flux = m->cfg.psi_f - m->dL * id;
    *dT = m->k_T * (flux - m->dL * did * iq);
    return m->k_T * flux * iq;
}

fs_dq fs_mtpa_step(fs_mtpa *m, float T_ref)
{
    float T = fabsf(T_ref);
    fs_dq out;
    int lo = m->seg, hi = FS_MTPA_N - 1;
    if (T >= m->T[hi]) {
        out.d = m->i_d[hi];
        out.q = m->i_q[hi];
    } else {
        /* the segment holding T (one only: the table rises), the last
         * step's first: the reference moves little in a sample, and the
         * six halvings cost some 90 instructions on a Cortex-M4F */
        if (m->T[lo] <= T && T < m->T[lo + 1]) {
            hi = lo + 1;
        } else {
            lo = 0;
            while (hi - lo > 1) {  /* bisection on the rising torque table */
                int mid = (lo + hi) / 2;
                if (m->T[mid] <= T) lo = mid; else hi = mid;
            }
            m->seg = lo;
        }
        /* i_q from the table, refined by a Newton step on the locus'
         * torque (the chord is a few % short in the first segment, where
         * T ~ a i_q + b i_q^3; exact without a magnet), i_d on the locus
         * from it */
        float s = (T - m->T[lo]) / (m->T[hi] - m->T[lo]);
        float iq = m->i_q[lo] + s * (m->i_q[hi] - m->i_q[lo]), T0, dT;
        if (m->tabulated) {   /* a flux map's locus: the table, linearly */
            out.q = iq;
            out.d = m->i_d[lo] + s * (m->i_d[hi] - m->i_d[lo]);
            if (T_ref < 0.0f) out.q = -out.q;
            return out;
        }
        if (m->cfg.psi_f <= 0.0f) {   /* reluctance only: T = 1.5 p (L_q - L_d) i_q^2 exactly */
            iq = sqrtf(T / (m->k_T * m->dL));
        } else {
            T0 = mtpa_locus_torque(m, iq, mtpa_locus_id(m, iq), &dT);
            if (dT > 0.0f) iq = fs_clampf(iq + (T - T0) / dT, m->i_q[lo], m->i_q[hi]);
        }
        out.q = iq;
        out.d = mtpa_locus_id(m, iq);
    }
    if (T_ref < 0.0f) out.q = -out.q;
    return out;
}
