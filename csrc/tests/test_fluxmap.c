/* fs-test-sources: control/fs_fluxmap.c control/fs_status.c
 *
 * fs_fluxmap: a map that is bilinear in each cell is given back exactly at
 * any current, its fluxes and its cells' slopes (the incremental
 * inductances); the mirror image below i_q = 0; beyond the grid the edge
 * cells' slopes go on (a linear extension, not a clamp); the q secant
 * inductance and its limit at i_q = 0; init refuses a grid that is not
 * finite and rising and a map whose flux falls with its own current.
 */
#include <stdint.h>
#include <string.h>

#include "control/fs_fluxmap.h"
#include "fs_test.h"

/* A cross-saturated machine that is bilinear in (i_d, |i_q|) by
 * construction, so that the bilinear map is exact on it: L_d falls with
 * |i_q| (Y), L_q with i_d (X). */
static const float PSI_F = 0.16f, L_D = 2.2e-3f, L_Q = 6e-3f, X = 4e-6f, Y = -2e-6f;   /* Wb/A^2 */
static float psi_d_of(float i_d, float i_q) { return PSI_F + L_D * i_d + Y * i_d * fabsf(i_q); }
static float psi_q_of(float i_d, float i_q) { return L_Q * i_q + X * i_d * i_q; }

static void fill(fs_fluxmap_table *t, float i_max)
{
    t->i_d0 = -i_max;
    t->di_d = 1.5f * i_max / (float)(FS_FLUXMAP_ND - 1);
    t->di_q = i_max / (float)(FS_FLUXMAP_NQ - 1);
    t->psi_scale = 5e-5f;   /* the largest flux, 1.3 Wb, in 26,000 counts */
    for (int k = 0; k < FS_FLUXMAP_ND; ++k)
        for (int l = 0; l < FS_FLUXMAP_NQ; ++l) {
            const float i_d = t->i_d0 + (float)k * t->di_d, i_q = (float)l * t->di_q;
            t->psi_d[k * FS_FLUXMAP_NQ + l] = (int16_t)lrintf(psi_d_of(i_d, i_q) / t->psi_scale);
            t->psi_q[k * FS_FLUXMAP_NQ + l] = (int16_t)lrintf(psi_q_of(i_d, i_q) / t->psi_scale);
        }
}

int main(void)
{
    const float i_max = 200.0f;
    fs_fluxmap_table t;
    fill(&t, i_max);
    fs_fluxmap m;
    FS_CHECK_EQ_INT(fs_fluxmap_init(&m, &t), FS_OK, "init");
    /* inside the grid, anywhere in a cell, and beyond it: exact under the
     * bilinear map and its linear extension, to the counts' rounding (half a
     * count a point: 2.5e-5 Wb, over a step 4e-6 H of a slope) */
    const float tol = 3e-5f;
    const float pts[][2] = {{0.0f, 0.0f}, {-37.3f, 51.1f}, {12.5f, -88.8f}, {-200.0f, 200.0f}, {99.9f, 3.3f},
                            {-225.0f, 150.0f}, {112.0f, -212.0f}, {-1.0f, -0.01f}};
    for (size_t n = 0; n < sizeof pts / sizeof pts[0]; ++n) {
        const fs_dq i = {pts[n][0], pts[n][1]};
        const fs_fluxmap_point p = fs_fluxmap_eval(&m, i);
        /* the mirror image: psi_q odd in i_q, psi_d even (the test's psi_d has no i_q part) */
        FS_CHECK_NEAR(p.psi.d, psi_d_of(i.d, i.q), tol, "psi_d");
        const float q = psi_q_of(i.d, fabsf(i.q));
        FS_CHECK_NEAR(p.psi.q, i.q < 0.0f ? -q : q, tol, "psi_q");
        FS_CHECK_NEAR(p.L_dd, L_D + Y * fabsf(i.q), 5e-6f, "L_dd (the cell's slope along d)");
        FS_CHECK_NEAR(p.L_qq, L_Q + X * i.d, 5e-6f, "L_qq (the cell's slope along q)");
        const float L_s = fs_fluxmap_secant_q(&m, i, &p);
        FS_CHECK_NEAR(L_s, fabsf(i.q) > 0.1f * t.di_q ? p.psi.q / i.q : p.L_qq, 1e-9f, "the q secant");
    }
    fs_fluxmap_point p0 = fs_fluxmap_eval(&m, (fs_dq){30.0f, 0.0f});
    FS_CHECK_NEAR(fs_fluxmap_secant_q(&m, (fs_dq){30.0f, 0.0f}, &p0), L_Q + X * 30.0f, 5e-6f, "secant at i_q = 0: the incremental");

    /* a current that is not finite reads inside the table (the sanitizers see any read outside it, and
     * the index's overflow where a NaN was cast): a NaN gives NaN, not a value from elsewhere */
    const float bad[][2] = {{NAN, 10.0f}, {10.0f, NAN}, {NAN, NAN}, {INFINITY, 5.0f}, {-INFINITY, -5.0f}, {5.0f, INFINITY}};
    for (size_t n = 0; n < sizeof bad / sizeof bad[0]; ++n) {
        const fs_dq i = {bad[n][0], bad[n][1]};
        const fs_fluxmap_point p = fs_fluxmap_eval(&m, i);
        float L_dd;
        float L_qq;
        fs_fluxmap_slopes(&m, i, &L_dd, &L_qq);
        if (isnan(i.d) || isnan(i.q)) {
            FS_CHECK(isnan(p.psi.d) || isnan(p.psi.q), "a NaN current: NaN flux");
            FS_CHECK(isnan(L_dd) || isnan(L_qq), "a NaN current: NaN slopes");
        }
    }

    /* refusals */
    fs_fluxmap_table b = t;
    b.di_d = 0.0f;                FS_CHECK_EQ_INT(fs_fluxmap_init(&m, &b), FS_ERR_PARAM, "di_d 0");
    b = t; b.di_q = NAN;          FS_CHECK_EQ_INT(fs_fluxmap_init(&m, &b), FS_ERR_PARAM, "di_q NaN");
    b = t; b.psi_scale = -1.0f;   FS_CHECK_EQ_INT(fs_fluxmap_init(&m, &b), FS_ERR_PARAM, "scale < 0");
    b = t; b.i_d0 = INFINITY;     FS_CHECK_EQ_INT(fs_fluxmap_init(&m, &b), FS_ERR_PARAM, "i_d0 inf");
    b = t; b.psi_d[5 * FS_FLUXMAP_NQ + 3] = b.psi_d[4 * FS_FLUXMAP_NQ + 3];
    FS_CHECK_EQ_INT(fs_fluxmap_init(&m, &b), FS_ERR_LD, "psi_d not rising with i_d");
    b = t; b.psi_q[7 * FS_FLUXMAP_NQ + 9] = b.psi_q[7 * FS_FLUXMAP_NQ + 8] - 1;
    FS_CHECK_EQ_INT(fs_fluxmap_init(&m, &b), FS_ERR_LQ, "psi_q falling with i_q");
    FS_CHECK_EQ_INT(fs_fluxmap_init(NULL, &t), FS_ERR_NULL, "null");
    return fs_test_summary("test_fluxmap");
}
