#include "fs_mtpa.h"
#include "fs_math.h"

#include <stddef.h>

static float mtpa_id(const fs_mtpa_config *c, float I)
{
    float ret;
    float dL = c->L_q - c->L_d;
    if (dL <= (1e-9f * c->L_q)) { ret = 0.0f; }
    else {
        ret = (c->psi_f - sqrtf((c->psi_f * c->psi_f) + (8.0f * dL * dL * I * I))) / (4.0f * dL);
    }
    return ret;
}

/* Torque per (flux x current): (phases / 2) p. */
static float mtpa_k(const fs_mtpa_config *c) { return 0.5f * (float)c->phases * (float)c->pole_pairs; }

/* The map's torque at current magnitude I and angle g (from the d axis). */
static float mtpa_map_torque(const fs_mtpa *m, float I, float g, fs_dq *i)
{
    const float _Complex e = fs_cis(g);   /* the drive's own trigonometry: no libm sinf/cosf in the image */
    i->d = I * fs_cre(e);
    i->q = I * fs_cim(e);
    const fs_fluxmap_point p = fs_fluxmap_eval(m->cfg.map, *i);
    return m->k_T * ((p.psi.d * i->q) - (p.psi.q * i->d));
}

/* The locus on a flux map (fs_mtpa.h): per magnitude the angle of most
 * torque in [0, pi] (a positive d current where the map's d path is the
 * larger inductance), golden-section search to 1e-5 rad (the torque is
 * flat at its maximum: its error is below 1e-9 of it). The torque must rise
 * with the magnitude (a map that makes none is refused). */
static FS_COLD fs_status mtpa_search(fs_mtpa *m)
{
    const float r = 0.618034f;
    fs_status ret = FS_OK;
    m->i_d[0] = 0.0f;
    m->i_q[0] = 0.0f;
    m->T[0] = 0.0f;
    for (int k = 1; (k < FS_MTPA_N) && (ret == FS_OK); ++k) {
        const float I = m->cfg.i_max * (float)k / (float)(FS_MTPA_N - 1);
        float lo = 0.0f;
        float hi = FS_PI;
        fs_dq i;
        float g1 = hi - (r * (hi - lo));
        float g2 = lo + (r * (hi - lo));
        float T1 = mtpa_map_torque(m, I, g1, &i);
        float T2 = mtpa_map_torque(m, I, g2, &i);
        while ((hi - lo) > 1e-5f) {
            if (T1 < T2) {   /* the maximum is right of g1 */
                lo = g1; g1 = g2; T1 = T2;
                g2 = lo + (r * (hi - lo));
                T2 = mtpa_map_torque(m, I, g2, &i);
            } else {
                hi = g2; g2 = g1; T2 = T1;
                g1 = hi - (r * (hi - lo));
                T1 = mtpa_map_torque(m, I, g1, &i);
            }
        }
        m->T[k] = mtpa_map_torque(m, I, 0.5f * (lo + hi), &i);
        m->i_d[k] = i.d;
        m->i_q[k] = i.q;
        if (!((m->T[k] > m->T[k - 1]) && (m->T[k] < INFINITY))) { ret = FS_ERR_PARAM; }
    }
    return ret;
}

/* fs_mtpa_init's design once its configuration is checked: the table, on the map's locus or the closed form's */
static FS_COLD fs_status mtpa_table(fs_mtpa *m, const fs_mtpa_config *cfg)
{
    fs_status ret = FS_OK;
    m->cfg = *cfg;
    m->tabulated = cfg->map != NULL;
    m->k_T = mtpa_k(cfg);
    m->seg = 0;
    m->dL = cfg->L_q - cfg->L_d;
    m->dL2 = 2.0f * m->dL;
    m->dL4 = 4.0f * m->dL * m->dL;
    m->psi2 = cfg->psi_f * cfg->psi_f;
    m->salient = m->dL > (1e-9f * cfg->L_q);
    if (cfg->map != NULL) {
        ret = mtpa_search(m);
        m->cfg.map = NULL;   /* not kept: the table is all the step needs */
    } else {
        for (int k = 0; (k < FS_MTPA_N) && (ret == FS_OK); ++k) {
            float I = cfg->i_max * (float)k / (float)(FS_MTPA_N - 1);
            float id = mtpa_id(cfg, I);
            float iq = sqrtf(fs_maxf((I * I) - (id * id), 0.0f));
            m->i_d[k] = id;
            m->i_q[k] = iq;
            m->T[k] = mtpa_k(cfg) * (cfg->psi_f + (cfg->L_d - cfg->L_q) * id) * iq;
            /* the torque must rise, finite: not without torque (psi_f = 0 and
             * L_q = L_d), nor beyond the float range */
            if ((k > 0) && !((m->T[k] > m->T[k - 1]) && (m->T[k] < INFINITY))) { ret = FS_ERR_PARAM; }
        }
    }
    return ret;
}

FS_COLD fs_status fs_mtpa_init(fs_mtpa *m, const fs_mtpa_config *cfg)
{
    fs_status ret = FS_OK;
    if (!m || !cfg) { ret = FS_ERR_NULL; }
    else if (!fs_pos(cfg->L_d)) { ret = FS_ERR_LD; }
    else if (!cfg->map && !(cfg->L_q >= cfg->L_d)) { ret = FS_ERR_LQ; }   /* the closed form assumes L_q >= L_d */
    else if (!fs_fin(cfg->L_q)) { ret = FS_ERR_LQ; }
    else if (!fs_nonneg(cfg->psi_f)) { ret = FS_ERR_PSI_F; }
    else if (cfg->pole_pairs < 1) { ret = FS_ERR_POLE_PAIRS; }
    else if ((cfg->phases != 3) && (cfg->phases != 5)) { ret = FS_ERR_PARAM; }
    else if (!fs_pos(cfg->i_max)) { ret = FS_ERR_I_MAX; }
    else { ret = mtpa_table(m, cfg); }
    return ret;
}

/* The MTPA locus as i_d(i_q): psi_f i_d + (L_d - L_q)(i_d^2 - i_q^2) = 0,
 * written without the cancellation of psi_f - sqrt(...) at small currents
 * (i_d = -i_q without a magnet). Inline: the step calls it twice; as a
 * call, each formed the address of every constant it reads (the firmware's
 * build on a Cortex-M4F, bench/pil.py: 24.7 instructions a step more). */
static inline float mtpa_locus_id(const fs_mtpa *m, float iq)
{
    float ret;
    if (m->cfg.psi_f <= 0.0f) { ret = -iq; }
    else if (!m->salient) { ret = 0.0f; }
    else {
        ret = -m->dL2 * iq * iq / (m->cfg.psi_f + sqrtf(m->psi2 + (m->dL4 * iq * iq)));
    }
    return ret;
}

/* The torque on the locus at (id, iq) and its slope d T / d i_q (the
 * second pass of a step needs i_d alone: apart, it skips this). */
static float mtpa_locus_torque(const fs_mtpa *m, float iq, float id, float *dT)
{
    const float did = (m->cfg.psi_f <= 0.0f) ? -1.0f : (m->salient ? m->dL2 * iq / ((m->dL2 * id) - m->cfg.psi_f) : 0.0f);
    const float flux = m->cfg.psi_f - (m->dL * id);
    *dT = m->k_T * (flux - (m->dL * did * iq));
    return m->k_T * flux * iq;
}

fs_dq fs_mtpa_step(fs_mtpa *m, float T_ref)
{
    float T = fabsf(T_ref);
    fs_dq out;
    int lo = m->seg;
    int hi = FS_MTPA_N - 1;
    if (T >= m->T[hi]) {
        out.d = m->i_d[hi];
        out.q = m->i_q[hi];
    } else {
        /* the segment holding T (one only: the table rises), the last
         * step's first: the reference moves little in a sample, and the
         * six halvings cost some 90 instructions on a Cortex-M4F */
        if ((m->T[lo] <= T) && (T < m->T[lo + 1])) {
            hi = lo + 1;
        } else {
            lo = 0;
            while ((hi - lo) > 1) {  /* bisection on the rising torque table */
                int mid = (lo + hi) / 2;
                if (m->T[mid] <= T) { lo = mid; } else { hi = mid; }
            }
            m->seg = lo;
        }
        /* i_q from the table, refined by a Newton step on the locus'
         * torque (the chord is a few % short in the first segment, where
         * T ~ a i_q + b i_q^3; exact without a magnet), i_d on the locus
         * from it */
        float s = (T - m->T[lo]) / (m->T[hi] - m->T[lo]);
        float iq = m->i_q[lo] + (s * (m->i_q[hi] - m->i_q[lo]));
        if (m->tabulated != 0) {   /* a flux map's locus: its table, linearly */
            out.q = iq;
            out.d = m->i_d[lo] + (s * (m->i_d[hi] - m->i_d[lo]));
            if (T_ref < 0.0f) { out.q = -out.q; }
            return out;
        }
        if (m->cfg.psi_f <= 0.0f) {   /* reluctance only: T = 1.5 p (L_q - L_d) i_q^2 exactly */
            iq = sqrtf(T / (m->k_T * m->dL));
        } else {
            float dT;
            const float T0 = mtpa_locus_torque(m, iq, mtpa_locus_id(m, iq), &dT);
            if (dT > 0.0f) { iq = fs_clampf(iq + (T - T0) / dT, m->i_q[lo], m->i_q[hi]); }
        }
        out.q = iq;
        out.d = mtpa_locus_id(m, iq);
    }
    if (T_ref < 0.0f) { out.q = -out.q; }
    return out;
}
