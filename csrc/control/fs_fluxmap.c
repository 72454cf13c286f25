#include "fs_fluxmap.h"
#include "fs_math.h"

FS_COLD fs_status fs_fluxmap_init(fs_fluxmap *m, const fs_fluxmap_table *t)
{
    fs_status ret = FS_OK;
    if (!m || !t) { ret = FS_ERR_NULL; }
    else if (!fs_pos(t->di_d) || !fs_pos(t->di_q) || !fs_fin(t->i_d0) || !fs_pos(t->psi_scale)) { ret = FS_ERR_PARAM; }
    else {
        /* the first point (k, then l) where a flux does not rise names its axis */
        for (int k = 0; (k < FS_FLUXMAP_ND) && (ret == FS_OK); ++k) {
            for (int l = 0; (l < FS_FLUXMAP_NQ) && (ret == FS_OK); ++l) {
                const int n = (k * FS_FLUXMAP_NQ) + l;
                if ((k > 0) && !(t->psi_d[n] > t->psi_d[n - FS_FLUXMAP_NQ])) { ret = FS_ERR_LD; }
                else if ((l > 0) && !(t->psi_q[n] > t->psi_q[n - 1])) { ret = FS_ERR_LQ; }
                else { /* both rise */ }
            }
        }
        if (ret == FS_OK) {
            m->t = t;
            m->inv_di_d = 1.0f / t->di_d;
            m->inv_di_q = 1.0f / t->di_q;
        }
    }
    return ret;
}

fs_fluxmap_point fs_fluxmap_eval(const fs_fluxmap *m, fs_dq i)
{
    const fs_fluxmap_table *t = m->t;
    /* the cell, and the position in it (beyond the grid's edge: outside [0, 1], its slope goes on) */
    const float x = (i.d - t->i_d0) * m->inv_di_d;
    const float y = fabsf(i.q) * m->inv_di_q;
    const int k = (int)fs_clampf(x, 0.0f, (float)(FS_FLUXMAP_ND - 2));
    const int l = (int)fs_clampf(y, 0.0f, (float)(FS_FLUXMAP_NQ - 2));
    const float a = x - (float)k;
    const float b = y - (float)l;
    const int n = (k * FS_FLUXMAP_NQ) + l;
    const int16_t *d = &t->psi_d[n];
    const int16_t *q = &t->psi_q[n];
    /* corners: [0] (k, l), [1] (k, l + 1), [NQ] (k + 1, l), [NQ + 1] (k + 1, l + 1) */
    const float d00 = d[0];
    const float d01 = d[1];
    const float d10 = d[FS_FLUXMAP_NQ];
    const float d11 = d[FS_FLUXMAP_NQ + 1];
    const float q00 = q[0];
    const float q01 = q[1];
    const float q10 = q[FS_FLUXMAP_NQ];
    const float q11 = q[FS_FLUXMAP_NQ + 1];
    const float dd0 = d10 - d00;                             /* along d at l and l + 1 */
    const float dd1 = d11 - d01;
    const float dq0 = q01 - q00;                             /* along q at k and k + 1 */
    const float dq1 = q11 - q10;
    const float s = t->psi_scale;
    fs_fluxmap_point p;
    p.psi.d = s * (d00 + (a * dd0) + (b * ((d01 - d00) + (a * (dd1 - dd0)))));
    p.psi.q = s * (q00 + (b * dq0) + (a * ((q10 - q00) + (b * (dq1 - dq0)))));
    if (i.q < 0.0f) { p.psi.q = -p.psi.q; }
    p.L_dd = s * m->inv_di_d * (dd0 + (b * (dd1 - dd0)));
    p.L_qq = s * m->inv_di_q * (dq0 + (a * (dq1 - dq0)));
    /* along q of psi_d and along d of psi_q; the mirror image turns the sign of d psi_d / d i_q below i_q = 0 */
    const float sq = (i.q < 0.0f) ? -1.0f : 1.0f;
    p.L_dq = sq * s * m->inv_di_q * ((d01 - d00) + (a * (dd1 - dd0)));
    p.L_qd = sq * s * m->inv_di_d * ((q10 - q00) + (b * (dq1 - dq0)));
    return p;
}

float fs_fluxmap_secant_q(const fs_fluxmap *m, fs_dq i, const fs_fluxmap_point *p)
{
    return (fabsf(i.q) > (0.1f * m->t->di_q)) ? (p->psi.q / i.q) : p->L_qq;
}
