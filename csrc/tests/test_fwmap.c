/* fs-test-sources: control/fs_fwmap.c control/fs_mtpa.c control/fs_fluxmap.c control/fs_transforms.c control/fs_status.c
 *
 * fs_fwmap on a saturating IPMSM's map (the 2004 Prius MG2 as the trial
 * built it: secant L(i) = L0 / (1 + |i| / a) per axis): at each row's flux
 * limit, T_max is the most torque a brute-force search over the current
 * disc finds within both limits (to 1 % of it, the march's resolution);
 * every tabulated current lies within both limits and makes its row's
 * torque; the table's rows fall with the speed ratio; below base speed
 * (x <= 1) the step is not asked, above X_MAX the last row holds; the
 * step's torque is held at T_max, and its current makes the torque asked
 * (to the interpolation's 3 %). On a linear SPM whose characteristic
 * current lies beyond i_max (a hub motor's): the rows end at its top speed,
 * and beyond it the step asks for the least flux, -i_max on d, no torque.
 */
#include <stdint.h>
#include <string.h>

#include "control/fs_fwmap.h"
#include "fs_test.h"

static const float PSI_F = 0.1607f, LD0 = 2.26e-3f, LQ0 = 6.15e-3f, I_MAX = 250.0f, K_T = 6.0f;
static float psi_d_of(float i_d) { return PSI_F + LD0 * i_d / (1.0f + fabsf(i_d) / 977.0f); }
static float psi_q_of(float i_q) { return LQ0 * i_q / (1.0f + fabsf(i_q) / 238.0f); }

/* the controller's grid (fs_fluxmap.h) over [-i_max, i_max / 2] x [0, i_max], fluxes up to psi_top */
static void fill_table(fs_fluxmap_table *t, float i_max, float psi_top, float (*psi_d)(float), float (*psi_q)(float))
{
    t->i_d0 = -i_max;
    t->di_d = 1.5f * i_max / (float)(FS_FLUXMAP_ND - 1);
    t->di_q = i_max / (float)(FS_FLUXMAP_NQ - 1);
    t->psi_scale = psi_top / 32000.0f;
    for (int k = 0; k < FS_FLUXMAP_ND; ++k)
        for (int l = 0; l < FS_FLUXMAP_NQ; ++l) {
            t->psi_d[k * FS_FLUXMAP_NQ + l] = (int16_t)lrintf(psi_d(t->i_d0 + (float)k * t->di_d) / t->psi_scale);
            t->psi_q[k * FS_FLUXMAP_NQ + l] = (int16_t)lrintf(psi_q((float)l * t->di_q) / t->psi_scale);
        }
}

/* a linear SPM with its characteristic current beyond i_max (test_top_speed) */
static const float SPM_PSI_F = 0.02f, SPM_L = 1.3e-4f, SPM_I_MAX = 45.0f;
static float spm_psi_d(float i_d) { return SPM_PSI_F + SPM_L * i_d; }
static float spm_psi_q(float i_q) { return SPM_L * i_q; }

static float torque(const fs_fluxmap *m, float i_d, float i_q, float *psi)
{
    const fs_fluxmap_point p = fs_fluxmap_eval(m, (fs_dq){i_d, i_q});
    *psi = sqrtf(p.psi.d * p.psi.d + p.psi.q * p.psi.q);
    return K_T * (p.psi.d * i_q - p.psi.q * i_d);
}

/* psi_d = psi_f + L i_d, psi_q = L i_q with psi_f / L = 3.4 i_max: x_top =
 * |psi(MTPA at i_max)| / (psi_f - L i_max) */
static void test_top_speed(void)
{
    const float psi_f = SPM_PSI_F, L = SPM_L, i_max = SPM_I_MAX, k_T = 34.5f;
    fs_fluxmap_table t;
    fill_table(&t, i_max, 0.03f, spm_psi_d, spm_psi_q);
    fs_fluxmap map;
    FS_CHECK_EQ_INT(fs_fluxmap_init(&map, &t), FS_OK, "SPM map");
    fs_mtpa_config mc = {L, L, psi_f, 23, i_max, 3, &map};
    fs_mtpa mtpa;
    FS_CHECK_EQ_INT(fs_mtpa_init(&mtpa, &mc), FS_OK, "SPM mtpa");
    fs_fwmap_config wc = {&map, i_max, k_T, 1e-4f, 3000.0f};
    fs_fwmap f;
    FS_CHECK_EQ_INT(fs_fwmap_init(&f, &wc, &mtpa), FS_OK, "SPM init");
    const float x_top = sqrtf(psi_f * psi_f + L * L * i_max * i_max) / (psi_f - L * i_max);
    FS_CHECK_NEAR(1.0f + 1.0f / f.inv_dx, x_top, 2e-3f * x_top, "the rows end at the top speed's ratio");
    FS_CHECK(f.T_max[FS_FWMAP_NX - 2] > 0.0f && f.T_max[FS_FWMAP_NX - 1] < 1e-3f * f.T_max[0],
             "torque up to the top speed, none at it (%g, %g)", f.T_max[FS_FWMAP_NX - 2], f.T_max[FS_FWMAP_NX - 1]);
    float T_real;
    const fs_dq i = fs_fwmap_step(&f, 1.2f * x_top, 1e9f, &T_real);
    FS_CHECK(T_real == 0.0f && fabsf(i.d + i_max) <= 0.02f * i_max && i.q == 0.0f,
             "beyond the top speed the least flux: i (%g, %g), T %g", i.d, i.q, T_real);
    const fs_dq i_n = fs_fwmap_step(&f, 0.99f * x_top, 1e9f, &T_real);
    FS_CHECK(T_real > 0.0f && i_n.d < -0.9f * i_max, "just below it: some torque, deep on d (%g, %g)", i_n.d, i_n.q);
}

int main(void)
{
    test_top_speed();
    fs_fluxmap_table t;
    fill_table(&t, I_MAX, 1.2f, psi_d_of, psi_q_of);
    fs_fluxmap map;
    FS_CHECK_EQ_INT(fs_fluxmap_init(&map, &t), FS_OK, "map");
    fs_mtpa_config mc = {2e-3f, 4e-3f, PSI_F, 4, I_MAX, 3, &map};
    fs_mtpa mtpa;
    FS_CHECK_EQ_INT(fs_mtpa_init(&mtpa, &mc), FS_OK, "mtpa");
    fs_fwmap_config wc = {&map, I_MAX, K_T, 1e-4f, 3000.0f};
    fs_fwmap f;
    FS_CHECK_EQ_INT(fs_fwmap_init(&f, &wc, &mtpa), FS_OK, "init");
    float psi_top;
    torque(&map, mtpa.i_d[FS_MTPA_N - 1], mtpa.i_q[FS_MTPA_N - 1], &psi_top);
    FS_CHECK_NEAR(f.psi_mtpa, psi_top, 1e-5f, "psi_mtpa: MTPA's flux at i_max");
    FS_CHECK_NEAR(f.T_max[0], mtpa.T[FS_MTPA_N - 1], 1e-3f * mtpa.T[FS_MTPA_N - 1], "x = 1: MTPA's torque at i_max");
    for (int k = 0; k < FS_FWMAP_NX; ++k) {
        const float s = (float)k / (float)(FS_FWMAP_NX - 1);
        const float x = 1.0f + (FS_FWMAP_X_MAX - 1.0f) * s * s, psi_lim = f.psi_mtpa / x;
        /* brute force over the disc, 0.5 A steps */
        float best = 0.0f;
        for (float i_d = -I_MAX; i_d <= 0.0f; i_d += 0.5f)
            for (float i_q = 0.0f; i_d * i_d + i_q * i_q <= I_MAX * I_MAX; i_q += 0.5f) {
                float psi;
                const float T = torque(&map, i_d, i_q, &psi);
                if (psi <= psi_lim && T > best) best = T;
            }
        FS_CHECK(fabsf(f.T_max[k] - best) <= 0.01f * best + 0.05f, "row %d (x %.2f): T_max %g, the disc's best %g", k, x, f.T_max[k], best);
        if (k > 0) FS_CHECK(f.T_max[k] < f.T_max[k - 1], "T_max falls with x (row %d)", k);
        for (int j = 1; j < FS_FWMAP_NT; ++j) {
            const int n = k * FS_FWMAP_NT + j;
            float psi;
            const float T = torque(&map, f.i_d[n], f.i_q[n], &psi);
            const float T_j = f.T_max[k] * (float)j / (float)(FS_FWMAP_NT - 1);
            FS_CHECK(psi <= 1.001f * psi_lim, "row %d, point %d: flux %g within %g", k, j, psi, psi_lim);
            FS_CHECK(f.i_d[n] * f.i_d[n] + f.i_q[n] * f.i_q[n] <= 1.0001f * I_MAX * I_MAX, "row %d, point %d: within i_max", k, j);
            FS_CHECK(fabsf(T - T_j) <= 0.005f * f.T_max[k], "row %d, point %d: torque %g for %g", k, j, T, T_j);
        }
    }
    /* the step: T held at T_max, the current's torque the one asked */
    for (float x = 1.05f; x < 7.9f; x *= 1.3f) {
        for (float share = 0.2f; share < 1.5f; share += 0.3f) {
            float T_real;
            const fs_dq i0 = fs_fwmap_step(&f, x, 1e9f, &T_real);   /* T_max at x */
            const float T_ref = share * T_real;
            float T_r2, psi;
            const fs_dq i = fs_fwmap_step(&f, x, -T_ref, &T_r2);
            FS_CHECK(T_r2 <= 0.0f && -T_r2 <= T_real * 1.0001f, "the torque held at T_max (x %g)", x);
            const float T = torque(&map, i.d, -i.q, &psi);
            FS_CHECK(fabsf(T + T_r2) <= 0.03f * T_real, "x %g, %g of T_max: the current's torque %g for %g", x, share, T, -T_r2);
            FS_CHECK(i.q <= 0.0f, "negative torque: negative i_q");
            (void)i0;
        }
    }
    float T_a, T_b;
    const fs_dq a = fs_fwmap_step(&f, 8.0f, 1e9f, &T_a), b = fs_fwmap_step(&f, 20.0f, 1e9f, &T_b);
    FS_CHECK(a.d == b.d && a.q == b.q && T_a == T_b, "beyond X_MAX the last row holds");
    /* the trim raises x while the voltage asked exceeds the plan, and comes back: the flux at the current
     * on the plan's limit psi_mtpa / x (the references there), whatever the trim made of x */
    const float x0 = fs_fwmap_ratio(&f, 250.0f, 1000.0f);
    for (int n = 0; n < 100; ++n) {
        const float x = fs_fwmap_ratio(&f, 250.0f, 1000.0f);
        fs_fwmap_trim(&f, 280.0f, 260.0f, f.psi_mtpa / x, x);
    }
    FS_CHECK(fs_fwmap_ratio(&f, 250.0f, 1000.0f) > x0 * 1.05f, "the trim deepens the flux weakening");
    const float x_up = fs_fwmap_ratio(&f, 250.0f, 1000.0f);
    /* below the plan with the current's flux inside the flux limit (MTPA at a light load) the trim holds:
     * a voltage below the plan is the operating point's there, not the plan's error (fs_fwmap.h) */
    for (int n = 0; n < 10000; ++n) {
        const float x = fs_fwmap_ratio(&f, 250.0f, 1000.0f);
        fs_fwmap_trim(&f, 200.0f, 260.0f, (1.0f - 2.0f * FS_FWMAP_INSIDE) * f.psi_mtpa / x, x);
    }
    FS_CHECK(fs_fwmap_ratio(&f, 250.0f, 1000.0f) == x_up, "inside the flux limit the trim holds");
    for (int n = 0; n < 10000; ++n) {
        const float x = fs_fwmap_ratio(&f, 250.0f, 1000.0f);
        fs_fwmap_trim(&f, 200.0f, 260.0f, f.psi_mtpa / x, x);
    }
    const float x_lo = 0.5f * x0 > 1.0f ? 0.5f * x0 : 1.0f;
    FS_CHECK_NEAR(fs_fwmap_ratio(&f, 250.0f, 1000.0f), x_lo, 1e-5f * x0,
                  "on the limit it lets it back, below the plan down to base speed (x = 1) or half the ratio");
    FS_CHECK_EQ_INT(fs_fwmap_init(&f, NULL, &mtpa), FS_ERR_NULL, "null");
    return fs_test_summary("test_fwmap");
}
