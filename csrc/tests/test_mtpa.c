/* fs-test-sources: control/fs_mtpa.c control/fs_fluxmap.c control/fs_transforms.c control/fs_status.c
 *
 * fs_mtpa: init validation; non-salient machine (i_d = 0, T = 1.5 p psi_f i_q);
 * salient machines: the returned current gives the reference torque within 1 %,
 * and is the maximum-torque-per-ampere current (at the same magnitude a current
 * angle 2 degrees either way gives less torque); negative torque mirrors i_q;
 * beyond the limit the current magnitude is i_max; the segment the last step
 * found (where step looks first) changes no result; a flux map's locus, searched
 * at init, is the closed form's on a linear machine's map.
 */
#include <stdint.h>
#include <string.h>

#include "control/fs_mtpa.h"
#include "tests/fs_test.h"

static double torque(const fs_mtpa_config *c, double id, double iq)
{
    return 0.5 * c->phases * c->pole_pairs * (c->psi_f + (c->L_d - c->L_q) * id) * iq;
}

static void salient(fs_mtpa_config c, const char *name)
{
    fs_mtpa m;
    FS_CHECK(fs_mtpa_init(&m, &c) == FS_OK, "%s: init", name);
    /* The torque at i_max on the analytic locus (double). */
    double T_lim = 0.0;
    {
        double I = c.i_max, dL = c.L_q - c.L_d;
        double id = (c.psi_f - sqrt(c.psi_f * c.psi_f + 8.0 * dL * dL * I * I)) / (4.0 * dL);
        T_lim = torque(&c, id, sqrt(I * I - id * id));
    }
    FS_CHECK_REL(m.T[FS_MTPA_N - 1], T_lim, 1e-4, 0, "table end");
    double prev_I = -1.0;
    for (int k = 1; k <= 199; ++k) {
        double T_ref = T_lim * k / 200.0;
        fs_dq i = fs_mtpa_step(&m, (float)T_ref);
        double I = hypot(i.d, i.q);
        double T = torque(&c, i.d, i.q);
        FS_CHECK_REL(T, T_ref, 0.01, 0, "torque of the MTPA current");
        FS_CHECK(i.d <= 0.0f && i.q > 0.0f, "%s: current (%g, %g) not in the second quadrant", name, i.d, i.q);
        FS_CHECK(I > prev_I, "%s: current magnitude not rising with torque", name);
        FS_CHECK(I <= c.i_max * (1 + 1e-5), "%s: |i| = %g beyond i_max", name, I);
        prev_I = I;
        /* MTPA: at the same magnitude, +-2 degrees of current angle lower the torque. */
        double beta = atan2(i.q, i.d), d = 2.0 * FS_TEST_PI / 180.0;
        double T_plus = torque(&c, I * cos(beta + d), I * sin(beta + d));
        double T_minus = torque(&c, I * cos(beta - d), I * sin(beta - d));
        FS_CHECK(T_plus < T && T_minus < T, "%s: T_ref %g: torque %g, at +2 deg %g, at -2 deg %g", name, T_ref, T,
                 T_plus, T_minus);
        /* And the optimum itself is within half a degree (the table is linear
         * between its 64 points: in the first segment, from the origin, the
         * angle is off by up to ~0.45 degrees; elsewhere by < 0.2). */
        double best = beta, T_best = T;
        for (int j = -200; j <= 200; ++j) {
            double b = beta + j * 1e-4;
            double Tj = torque(&c, I * cos(b), I * sin(b));
            if (Tj > T_best) { T_best = Tj; best = b; }
        }
        FS_CHECK(fabs(best - beta) < 0.5 * FS_TEST_PI / 180.0, "%s: angle %g deg from the optimum",
                 name, (best - beta) * 180.0 / FS_TEST_PI);
        /* Negative torque: same i_d, opposite i_q. */
        fs_dq n = fs_mtpa_step(&m, (float)-T_ref);
        FS_CHECK(n.d == i.d && n.q == -i.q, "%s: -T gives (%g, %g), +T (%g, %g)", name, n.d, n.q, i.d, i.q);
    }
    /* Small torques too (first table segment). */
    for (int k = 1; k <= 10; ++k) {
        double T_ref = T_lim * 1e-4 * k;
        fs_dq i = fs_mtpa_step(&m, (float)T_ref);
        FS_CHECK_REL(torque(&c, i.d, i.q), T_ref, 0.01, 0, "small torque");
    }
    /* Zero torque: zero current. */
    fs_dq z = fs_mtpa_step(&m, 0.0f);
    FS_CHECK(fabsf(z.d) < 1e-6f * c.i_max && fabsf(z.q) < 1e-6f * c.i_max, "%s: zero torque gives (%g, %g)",
             name, z.d, z.q);
    /* Beyond the limit: magnitude i_max, torque T_lim, both signs. */
    const float beyond[] = {(float)T_lim, (float)(1.5 * T_lim), (float)(100 * T_lim)};
    for (int k = 0; k < 3; ++k) {
        for (int s = -1; s <= 1; s += 2) {
            fs_dq i = fs_mtpa_step(&m, s * beyond[k]);
            FS_CHECK_REL(hypot(i.d, i.q), c.i_max, 1e-5, 0, "limit magnitude");
            FS_CHECK_REL(torque(&c, i.d, i.q), s * T_lim, 1e-4, 0, "limit torque");
        }
    }
}

/* One instance stepped through a sequence of torques (small moves, jumps,
 * both signs, the limit, NaN) gives the bits of a fresh instance at each. */
static void order_free(fs_mtpa_config c, const char *name)
{
    fs_mtpa run, fresh;
    FS_CHECK(fs_mtpa_init(&run, &c) == FS_OK, "%s: init", name);
    const float T_top = run.T[FS_MTPA_N - 1];
    uint32_t r = 7u;
    int moved = 0;
    for (int k = 0; k < 4000; ++k) {
        r = r * 1664525u + 1013904223u;
        const float u = (float)(r >> 8) / 16777216.0f;
        const float T = k % 500 == 499 ? NAN : k % 7 == 0 ? (2.4f * u - 1.2f) * T_top
                                                          : T_top * (0.3f + 0.01f * u) * (k % 2 ? 1.0f : -1.0f);
        const int seg = run.seg;
        const fs_dq a = fs_mtpa_step(&run, T);
        fs_mtpa_init(&fresh, &c);
        const fs_dq b = fs_mtpa_step(&fresh, T);
        moved += run.seg != seg;
        FS_CHECK(memcmp(&a, &b, sizeof a) == 0, "%s: step %d (T %g): (%.9g, %.9g) after others, (%.9g, %.9g) fresh",
                 name, k, T, a.d, a.q, b.d, b.q);
    }
    FS_CHECK(moved > 100, "%s: the segment moved %d times: the sequence did not exercise it", name, moved);
}

int main(void)
{
    fs_mtpa m;
    fs_mtpa_config c = {2e-3f, 6e-3f, 0.1f, 4, 20.0f, 3, NULL};
    FS_CHECK_EQ_INT(fs_mtpa_init(&m, &c), FS_OK, "init");
    FS_CHECK_EQ_INT(fs_mtpa_init(NULL, &c), FS_ERR_NULL, "null");
    FS_CHECK_EQ_INT(fs_mtpa_init(&m, NULL), FS_ERR_NULL, "null cfg");
    fs_mtpa_config b = c; b.L_d = 0.0f;  FS_CHECK_EQ_INT(fs_mtpa_init(&m, &b), FS_ERR_LD, "L_d = 0");
    b = c; b.L_q = 1e-3f;                FS_CHECK_EQ_INT(fs_mtpa_init(&m, &b), FS_ERR_LQ, "L_q < L_d");
    b = c; b.psi_f = -0.1f;              FS_CHECK_EQ_INT(fs_mtpa_init(&m, &b), FS_ERR_PSI_F, "psi_f < 0");
    b = c; b.pole_pairs = 0;             FS_CHECK_EQ_INT(fs_mtpa_init(&m, &b), FS_ERR_POLE_PAIRS, "p = 0");
    b = c; b.i_max = 0.0f;               FS_CHECK_EQ_INT(fs_mtpa_init(&m, &b), FS_ERR_I_MAX, "i_max = 0");
    b = c; b.psi_f = 0.0f; b.L_q = b.L_d; FS_CHECK_EQ_INT(fs_mtpa_init(&m, &b), FS_ERR_PARAM, "no torque");
    b = c; b.phases = 4;                 FS_CHECK_EQ_INT(fs_mtpa_init(&m, &b), FS_ERR_PARAM, "4 phases");
    b = c; b.phases = 0;                 FS_CHECK_EQ_INT(fs_mtpa_init(&m, &b), FS_ERR_PARAM, "0 phases");

    /* Non-salient: i_d = 0, T = 1.5 p psi_f i_q. */
    fs_mtpa_config ns = {4e-3f, 4e-3f, 0.08f, 3, 15.0f, 3, NULL};
    FS_CHECK_EQ_INT(fs_mtpa_init(&m, &ns), FS_OK, "non-salient init");
    const double T_ns = 1.5 * 3 * 0.08 * 15.0;
    for (int k = -25; k <= 25; ++k) {
        double T_ref = T_ns * k / 20.0;  /* includes beyond the limit */
        fs_dq i = fs_mtpa_step(&m, (float)T_ref);
        FS_CHECK(i.d == 0.0f, "non-salient: i_d = %g", i.d);
        double T_want = fabs(T_ref) > T_ns ? (T_ref > 0 ? T_ns : -T_ns) : T_ref;
        FS_CHECK_REL(1.5 * 3 * 0.08 * i.q, T_want, 1e-5, 1e-6, "non-salient torque");
    }

    /* Salient PM machines and a synchronous reluctance machine (psi_f = 0). */
    salient(c, "IPM 2/6 mH");
    fs_mtpa_config strong = {1e-3f, 8e-3f, 0.05f, 5, 100.0f, 3, NULL};
    salient(strong, "IPM strongly salient");
    fs_mtpa_config weak = {4e-3f, 4.4e-3f, 0.2f, 2, 30.0f, 3, NULL};
    salient(weak, "IPM weakly salient");
    fs_mtpa_config synrm = {5e-3f, 40e-3f, 0.0f, 2, 10.0f, 3, NULL};
    salient(synrm, "SynRM");
    fs_mtpa_config five = c; five.phases = 5;
    salient(five, "IPM 2/6 mH, five phases");
    order_free(c, "IPM 2/6 mH");
    order_free(synrm, "SynRM");
    /* the locus does not depend on the phases: a torque 5/3 larger on five
     * phases asks for the same currents */
    fs_mtpa m5;
    fs_mtpa_init(&m, &c);
    fs_mtpa_init(&m5, &five);
    for (int k = 1; k <= 10; ++k) {
        float T3 = 0.1f * (float)k * m.T[FS_MTPA_N - 1];
        fs_dq i3 = fs_mtpa_step(&m, T3), i5 = fs_mtpa_step(&m5, T3 * 5.0f / 3.0f);
        FS_CHECK_REL(i5.d, i3.d, 1e-4, 1e-5, "five phases: same i_d");
        FS_CHECK_REL(i5.q, i3.q, 1e-4, 1e-5, "five phases: same i_q");
    }
    /* SynRM MTPA is at 45 degrees: i_d = -i_q. */
    fs_mtpa_init(&m, &synrm);
    fs_dq s = fs_mtpa_step(&m, 1.0f);
    FS_CHECK_REL(s.d, -s.q, 1e-5, 0, "SynRM at 45 degrees");

    /* A flux map's locus, searched at init: the linear machine c as a map
     * (on the grid's points its fluxes are exact; between them the
     * bilinear map of a linear machine is exact too) gives c's locus to the
     * search's precision and the interpolation's chord (0.5 % of i_max);
     * the table's torque is the map's. */
    fs_mtpa d;
    fs_mtpa_init(&d, &c);
    fs_fluxmap_table tab;
    tab.i_d0 = -c.i_max;
    tab.di_d = 1.5f * c.i_max / (float)(FS_FLUXMAP_ND - 1);
    tab.di_q = c.i_max / (float)(FS_FLUXMAP_NQ - 1);
    tab.psi_scale = (c.psi_f + c.L_q * c.i_max) / 32000.0f;
    for (int k = 0; k < FS_FLUXMAP_ND; ++k) {
        for (int l = 0; l < FS_FLUXMAP_NQ; ++l) {
            const float i_d = tab.i_d0 + (float)k * tab.di_d, i_q = (float)l * tab.di_q;
            tab.psi_d[k * FS_FLUXMAP_NQ + l] = (int16_t)lrintf((c.psi_f + c.L_d * i_d) / tab.psi_scale);
            tab.psi_q[k * FS_FLUXMAP_NQ + l] = (int16_t)lrintf(c.L_q * i_q / tab.psi_scale);
        }
    }
    fs_fluxmap map;
    FS_CHECK_EQ_INT(fs_fluxmap_init(&map, &tab), FS_OK, "map init");
    fs_mtpa_config ct = c;
    ct.map = &map;
    fs_mtpa t;
    FS_CHECK_EQ_INT(fs_mtpa_init(&t, &ct), FS_OK, "map's locus");
    FS_CHECK(t.tabulated == 1 && t.cfg.map == NULL, "tabulated, the map not kept");
    for (int k = 0; k < FS_MTPA_N; ++k)
        FS_CHECK(fabsf(t.T[k] - d.T[k]) <= 1e-3f * d.T[k] + 1e-6f * d.T[FS_MTPA_N - 1], "the map's MTPA torque at point %d: %g vs %g", k, t.T[k], d.T[k]);
    for (int k = 1; k <= 99; ++k) {
        float T_ref = d.T[FS_MTPA_N - 1] * (float)k / 100.0f;
        fs_dq a = fs_mtpa_step(&d, T_ref), b2 = fs_mtpa_step(&t, -T_ref);
        FS_CHECK(fabsf(a.d - b2.d) < 0.005f * c.i_max && fabsf(a.q + b2.q) < 0.005f * c.i_max,
                 "map: (%g, %g) against the locus (%g, %g)", b2.d, -b2.q, a.d, a.q);
    }
    /* A map that makes no torque (no magnet, no saliency) is refused. */
    fs_fluxmap_table flat = tab;
    for (int n = 0; n < FS_FLUXMAP_N; ++n) {
        const int k = n / FS_FLUXMAP_NQ, l = n % FS_FLUXMAP_NQ;
        flat.psi_d[n] = (int16_t)(100 * k - 600);
        flat.psi_q[n] = (int16_t)(100 * l);   /* the same incremental inductance on both axes... */
    }
    flat.di_q = flat.di_d;                    /* ...per ampere: L_d = L_q, psi_f = 0 */
    flat.i_d0 = -6.0f * flat.di_d;
    FS_CHECK_EQ_INT(fs_fluxmap_init(&map, &flat), FS_OK, "a flat map is a map");
    FS_CHECK_EQ_INT(fs_mtpa_init(&t, &ct), FS_ERR_PARAM, "but makes no torque");
    return fs_test_summary("test_mtpa");
}
