#include "fs_mtpa.h"
#include "fs_math.h"

static float mtpa_id(const fs_mtpa_config *c, float I)
{
    float dL = c->L_q - c->L_d;
    if (dL <= 1e-9f * c->L_q) return 0.0f;
    return (c->psi_f - sqrtf(c->psi_f * c->psi_f + 8.0f * dL * dL * I * I)) / (4.0f * dL);
}

fs_status fs_mtpa_init(fs_mtpa *m, const fs_mtpa_config *cfg)
{
    if (!m || !cfg) return FS_ERR_NULL;
    if (!(cfg->L_d > 0.0f)) return FS_ERR_LD;
    if (!(cfg->L_q >= cfg->L_d)) return FS_ERR_LQ;  /* MTPA here assumes L_q >= L_d */
    if (!(cfg->psi_f >= 0.0f)) return FS_ERR_PSI_F;
    if (cfg->pole_pairs < 1) return FS_ERR_POLE_PAIRS;
    if (!(cfg->i_max > 0.0f)) return FS_ERR_I_MAX;
    if (cfg->psi_f == 0.0f && cfg->L_q == cfg->L_d) return FS_ERR_PARAM;  /* no torque */
    m->cfg = *cfg;
    for (int k = 0; k < FS_MTPA_N; ++k) {
        float I = cfg->i_max * (float)k / (float)(FS_MTPA_N - 1);
        float id = mtpa_id(cfg, I);
        float iq = sqrtf(fmaxf(I * I - id * id, 0.0f));
        m->i_d[k] = id;
        m->i_q[k] = iq;
        m->T[k] = 1.5f * (float)cfg->pole_pairs * (cfg->psi_f + (cfg->L_d - cfg->L_q) * id) * iq;
    }
    return FS_OK;
}

fs_dq fs_mtpa_step(const fs_mtpa *m, float T_ref)
{
    float T = fabsf(T_ref);
    fs_dq out;
    int lo = 0, hi = FS_MTPA_N - 1;
    if (T >= m->T[hi]) {
        out.d = m->i_d[hi];
        out.q = m->i_q[hi];
    } else {
        while (hi - lo > 1) {  /* bisection on the rising torque table */
            int mid = (lo + hi) / 2;
            if (m->T[mid] <= T) lo = mid; else hi = mid;
        }
        float s = (T - m->T[lo]) / (m->T[hi] - m->T[lo]);
        out.d = m->i_d[lo] + s * (m->i_d[hi] - m->i_d[lo]);
        out.q = m->i_q[lo] + s * (m->i_q[hi] - m->i_q[lo]);
    }
    if (T_ref < 0.0f) out.q = -out.q;
    return out;
}
