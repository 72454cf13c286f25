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

/* The cell (k, l) of a current, its first point's index and the position
 * (a, b) in it (beyond the grid's edge: outside [0, 1], its slope goes on). */
typedef struct {
    int k;
    int l;
    int n;
    float a;
    float b;
} fluxmap_cell;

static fluxmap_cell cell_of(const fs_fluxmap *m, fs_dq i)
{
    const fs_fluxmap_table *t = m->t;
    const float x = (i.d - t->i_d0) * m->inv_di_d;
    const float y = fabsf(i.q) * m->inv_di_q;
    fluxmap_cell c;
    /* clamped as fs_clampf would, but a NaN current takes cell 0 (its values then NaN, read inside the
     * table): cast to int, a NaN is undefined, and the index it made read anywhere */
    c.k = (int)((x >= 0.0f) ? fs_minf(x, (float)(FS_FLUXMAP_ND - 2)) : 0.0f);
    c.l = (int)((y >= 0.0f) ? fs_minf(y, (float)(FS_FLUXMAP_NQ - 2)) : 0.0f);
    c.a = x - (float)c.k;
    c.b = y - (float)c.l;
    c.n = (c.k * FS_FLUXMAP_NQ) + c.l;
    return c;
}

fs_fluxmap_point fs_fluxmap_eval(const fs_fluxmap *m, fs_dq i)
{
    const fs_fluxmap_table *t = m->t;
    const fluxmap_cell c = cell_of(m, i);
    const float a = c.a;
    const float b = c.b;
    const int n = c.n;
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

/* The slope of psi_d along d (counts per step) of the cell whose first
 * point is d[0], at the position b across it along q; and of psi_q along q
 * from q[0], at a along d. */
static float slope_d(const int16_t *d, float b)
{
    const float s0 = (float)d[FS_FLUXMAP_NQ] - (float)d[0];
    const float s1 = (float)d[FS_FLUXMAP_NQ + 1] - (float)d[1];
    return s0 + (b * (s1 - s0));
}

static float slope_q(const int16_t *q, float a)
{
    const float s0 = (float)q[1] - (float)q[0];
    const float s1 = (float)q[FS_FLUXMAP_NQ + 1] - (float)q[FS_FLUXMAP_NQ];
    return s0 + (a * (s1 - s0));
}

/* At position f (0..1) across a cell whose slope s0 stands at its centre,
 * between it and the slope of the cell before (f < 1/2) or after. */
static float slope_centred(float s_prev, float s0, float s_next, float f)
{
    return (f < 0.5f) ? (s0 + ((0.5f - f) * (s_prev - s0))) : (s0 + ((f - 0.5f) * (s_next - s0)));
}

void fs_fluxmap_slopes(const fs_fluxmap *m, fs_dq i, float *L_dd, float *L_qq)
{
    const fs_fluxmap_table *t = m->t;
    const fluxmap_cell c = cell_of(m, i);
    const int16_t *d = t->psi_d;
    const int16_t *q = t->psi_q;
    /* along d: the cells k - 1, k, k + 1 (none beyond the grid: the edge cell's slope) */
    const float sd = slope_d(&d[c.n], c.b);
    const float sd_p = (c.k > 0) ? slope_d(&d[c.n - FS_FLUXMAP_NQ], c.b) : sd;
    const float sd_n = (c.k < (FS_FLUXMAP_ND - 2)) ? slope_d(&d[c.n + FS_FLUXMAP_NQ], c.b) : sd;
    /* along q: l - 1 (below i_q = 0 the mirror image, whose slope is cell 0's), l, l + 1 */
    const float sq = slope_q(&q[c.n], c.a);
    const float sq_p = (c.l > 0) ? slope_q(&q[c.n - 1], c.a) : sq;
    const float sq_n = (c.l < (FS_FLUXMAP_NQ - 2)) ? slope_q(&q[c.n + 1], c.a) : sq;
    *L_dd = t->psi_scale * m->inv_di_d * slope_centred(sd_p, sd, sd_n, c.a);
    *L_qq = t->psi_scale * m->inv_di_q * slope_centred(sq_p, sq, sq_n, c.b);
}

float fs_fluxmap_secant_q(const fs_fluxmap *m, fs_dq i, const fs_fluxmap_point *p)
{
    return (fabsf(i.q) > (0.1f * m->t->di_q)) ? (p->psi.q / i.q) : p->L_qq;
}
