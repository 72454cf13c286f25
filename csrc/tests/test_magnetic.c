/* fs-test-sources: plant/fs_magnetic.c
 *
 * fs_magnetic (plant, double):
 *  LINEAR     fs_mag_current inverts fs_mag_flux (and the formulas hold);
 *  ALGEBRAIC  with a_dd = a_qq = a_dq = 0 equals LINEAR; with saturation:
 *             i = grad W (central differences of fs_mag_energy within 1e-6),
 *             reciprocal cross inductances (symmetric Jacobian), psi_d = psi_f
 *             at zero current, positive i_d saturates more than negative,
 *             i_q lowers psi_d (cross-saturation), fs_mag_flux inverts
 *             fs_mag_current; init rejects negative coefficients;
 *  FLUXMAP    a map tabulated from the linear model is inverted exactly (also
 *             outside the grid); a map tabulated from the saturated model is
 *             inverted by its Newton from any starting hint.
 */
#include "plant/fs_magnetic.h"
#include "tests/fs_test.h"

static fs_mag_config linear_cfg(void)
{
    fs_mag_config c = {0};
    c.kind = FS_MAG_LINEAR;
    c.L_d = 2e-3;
    c.L_q = 5e-3;
    c.psi_f = 0.1;
    return c;
}

static fs_mag_config sat_cfg(int variant)
{
    fs_mag_config c = linear_cfg();
    c.kind = FS_MAG_ALGEBRAIC;
    if (variant == 0) {  /* integer exponents */
        c.a_dd = 5e5; c.S = 4.0;
        c.a_qq = 2e4; c.T = 2.0;
        c.a_dq = 2e5; c.U = 1.0; c.V = 0.0;
    } else {             /* fractional exponents, another balance */
        c.a_dd = 3e3; c.S = 1.5;
        c.a_qq = 8e3; c.T = 1.7;
        c.a_dq = 4e4; c.U = 0.5; c.V = 1.3;
    }
    return c;
}

static void check_linear(fs_mag *m, const char *name)
{
    for (double id = -60.0; id <= 60.0; id += 7.5) {
        for (double iq = -60.0; iq <= 60.0; iq += 7.5) {
            double pd, pq, id2, iq2;
            fs_mag_flux(m, id, iq, &pd, &pq);
            FS_CHECK_REL(pd, 0.1 + 2e-3 * id, 1e-12, 1e-14, name);
            FS_CHECK_REL(pq, 5e-3 * iq, 1e-12, 1e-14, name);
            fs_mag_current(m, pd, pq, &id2, &iq2);
            FS_CHECK_REL(id2, id, 1e-10, 1e-10, name);
            FS_CHECK_REL(iq2, iq, 1e-10, 1e-10, name);
        }
    }
}

/* Jacobian d i / d psi by central differences. */
static void di_dpsi(fs_mag *m, double pd, double pq, double J[4])
{
    const double h = 1e-6;
    double a1, b1, a2, b2;
    fs_mag_current(m, pd + h, pq, &a1, &b1);
    fs_mag_current(m, pd - h, pq, &a2, &b2);
    J[0] = (a1 - a2) / (2 * h);  /* d i_d / d psi_d */
    J[2] = (b1 - b2) / (2 * h);  /* d i_q / d psi_d */
    fs_mag_current(m, pd, pq + h, &a1, &b1);
    fs_mag_current(m, pd, pq - h, &a2, &b2);
    J[1] = (a1 - a2) / (2 * h);  /* d i_d / d psi_q */
    J[3] = (b1 - b2) / (2 * h);  /* d i_q / d psi_q */
}

/* Incremental inductances d psi / d i by central differences of fs_mag_flux. */
static void dpsi_di(fs_mag *m, double id, double iq, double L[4])
{
    const double h = 1e-3;
    double a1, b1, a2, b2;
    fs_mag_flux(m, id + h, iq, &a1, &b1);
    fs_mag_flux(m, id - h, iq, &a2, &b2);
    L[0] = (a1 - a2) / (2 * h);  /* L_dd */
    L[2] = (b1 - b2) / (2 * h);  /* L_qd */
    fs_mag_flux(m, id, iq + h, &a1, &b1);
    fs_mag_flux(m, id, iq - h, &a2, &b2);
    L[1] = (a1 - a2) / (2 * h);  /* L_dq */
    L[3] = (b1 - b2) / (2 * h);  /* L_qq */
}

static void check_saturated(fs_mag_config c, const char *name)
{
    fs_mag m;
    FS_CHECK(fs_mag_init(&m, &c) == 0, "%s: init", name);
    /* psi_d = psi_f at zero current, both ways. */
    double pd, pq, id, iq;
    fs_mag_current(&m, c.psi_f, 0.0, &id, &iq);
    FS_CHECK_NEAR(id, 0.0, 1e-12, "i(psi_f, 0) d");
    FS_CHECK_NEAR(iq, 0.0, 1e-12, "i(psi_f, 0) q");
    fs_mag_flux(&m, 0.0, 0.0, &pd, &pq);
    FS_CHECK_NEAR(pd, c.psi_f, 1e-12, "psi_d(0, 0) = psi_f");
    FS_CHECK_NEAR(pq, 0.0, 1e-12, "psi_q(0, 0) = 0");

    /* i = grad W, and the Hessian (the inverse incremental inductance) is symmetric. */
    int cross_seen = 0;
    for (double psd = 0.02; psd <= 0.2001; psd += 0.015) {
        for (double psq = -0.15; psq <= 0.1501; psq += 0.025) {
            fs_mag_current(&m, psd, psq, &id, &iq);
            const double h = 1e-6;
            double gd = (fs_mag_energy(&m, psd + h, psq) - fs_mag_energy(&m, psd - h, psq)) / (2 * h);
            double gq = (fs_mag_energy(&m, psd, psq + h) - fs_mag_energy(&m, psd, psq - h)) / (2 * h);
            double scale = fmax(fabs(id) + fabs(iq), 1.0);  /* 1e-6 relative to the current, floor 1 A */
            FS_CHECK_NEAR(gd, id, 1e-6 * scale, "dW/dpsi_d = i_d");
            FS_CHECK_NEAR(gq, iq, 1e-6 * scale, "dW/dpsi_q = i_q");
            double J[4];
            di_dpsi(&m, psd, psq, J);
            FS_CHECK_REL(J[1], J[2], 1e-6, 1e-6 * (fabs(J[0]) + fabs(J[3])), "di_d/dpsi_q = di_q/dpsi_d");
            if (fabs(J[1]) > 1e-3 * fabs(J[0])) ++cross_seen;
            /* positive definite (energy convex): incremental inductances > 0 */
            FS_CHECK(J[0] > 0 && J[3] > 0 && J[0] * J[3] - J[1] * J[2] > 0, "%s: Hessian not positive definite", name);
            /* fs_mag_flux inverts fs_mag_current */
            double pd2, pq2;
            fs_mag_flux(&m, id, iq, &pd2, &pq2);
            FS_CHECK_NEAR(pd2, psd, 1e-9, "flux(current(psi)) d");
            FS_CHECK_NEAR(pq2, psq, 1e-9, "flux(current(psi)) q");
        }
    }
    FS_CHECK(cross_seen > 10, "%s: the cross-saturation term should be active (%d points)", name, cross_seen);

    /* Reciprocal cross inductances from fs_mag_flux (L_dq = L_qd). */
    for (double i_d = -30.0; i_d <= 30.0; i_d += 10.0) {
        for (double i_q = -30.0; i_q <= 30.0; i_q += 10.0) {
            double L[4];
            dpsi_di(&m, i_d, i_q, L);
            FS_CHECK_REL(L[1], L[2], 1e-5, 1e-10, "L_dq = L_qd");
        }
    }

    /* Saturation asymmetry: positive i_d gives a smaller incremental L_dd. */
    for (double I = 5.0; I <= 40.0; I += 5.0) {
        double Lp[4], Ln[4], L0[4];
        dpsi_di(&m, I, 0.0, Lp);
        dpsi_di(&m, -I, 0.0, Ln);
        dpsi_di(&m, 0.0, 0.0, L0);
        FS_CHECK(Lp[0] < L0[0] && L0[0] < Ln[0], "%s: L_dd(+%g A) = %g, L_dd(0) = %g, L_dd(-%g A) = %g", name, I,
                 Lp[0], L0[0], I, Ln[0]);
        FS_CHECK(Ln[0] <= c.L_d * (1 + 1e-6), "%s: incremental L_dd above the unsaturated L_d", name);
    }
    /* Cross-saturation: i_q lowers psi_d at i_d = 0 (either sign of i_q). */
    for (double i_q = -40.0; i_q <= 40.0; i_q += 10.0) {
        if (i_q == 0.0) continue;
        fs_mag_flux(&m, 0.0, i_q, &pd, &pq);
        FS_CHECK(pd < c.psi_f, "%s: psi_d(0, %g) = %.12g not below psi_f", name, i_q, pd);
        double pd_m, pq_m;
        fs_mag_flux(&m, 0.0, -i_q, &pd_m, &pq_m);
        FS_CHECK_REL(pd_m, pd, 1e-10, 1e-14, "psi_d even in i_q");
        FS_CHECK_REL(pq_m, -pq, 1e-10, 1e-14, "psi_q odd in i_q");
    }
}

int main(void)
{
    /* LINEAR */
    fs_mag m;
    fs_mag_config lc = linear_cfg();
    FS_CHECK(fs_mag_init(&m, &lc) == 0, "linear init");
    check_linear(&m, "LINEAR");
    FS_CHECK_NEAR(fs_mag_energy(&m, 0.1, 0.0), 0.0, 1e-15, "linear energy at zero current");
    fs_mag_config bad = lc;
    bad.L_d = 0.0;
    FS_CHECK(fs_mag_init(&m, &bad) == FS_ERR_LD, "L_d = 0 accepted");
    bad = lc;
    bad.L_q = -1e-3;
    FS_CHECK(fs_mag_init(&m, &bad) == FS_ERR_LQ, "L_q < 0 accepted");
    bad = lc;
    bad.kind = 7;
    FS_CHECK(fs_mag_init(&m, &bad) == FS_ERR_MODE, "unknown kind accepted");

    /* ALGEBRAIC without saturation terms equals LINEAR. */
    fs_mag_config ac = lc;
    ac.kind = FS_MAG_ALGEBRAIC;
    ac.S = 5.0; ac.T = 1.0; ac.U = 1.0; ac.V = 0.0;
    fs_mag ma, ml;
    FS_CHECK(fs_mag_init(&ma, &ac) == 0 && fs_mag_init(&ml, &lc) == 0, "algebraic init");
    check_linear(&ma, "ALGEBRAIC, no saturation");
    for (double pd = -0.2; pd <= 0.3; pd += 0.01) {
        for (double pq = -0.3; pq <= 0.3; pq += 0.02) {
            double a1, b1, a2, b2;
            fs_mag_current(&ma, pd, pq, &a1, &b1);
            fs_mag_current(&ml, pd, pq, &a2, &b2);
            FS_CHECK_REL(a1, a2, 1e-12, 1e-11, "algebraic(0) i_d = linear");
            FS_CHECK_REL(b1, b2, 1e-12, 1e-11, "algebraic(0) i_q = linear");
            /* energies differ by a constant (the reference of W) */
            double dW = fs_mag_energy(&ma, pd, pq) - fs_mag_energy(&ml, pd, pq);
            FS_CHECK_NEAR(dW, -0.5 * 0.1 * 0.1 / 2e-3, 1e-12, "energy offset");
        }
    }

    /* ALGEBRAIC with saturation. */
    check_saturated(sat_cfg(0), "ALGEBRAIC S=4 T=2 U=1 V=0");
    check_saturated(sat_cfg(1), "ALGEBRAIC fractional exponents");
    bad = sat_cfg(0);
    bad.a_dd = -1.0;
    FS_CHECK(fs_mag_init(&m, &bad) == FS_ERR_PARAM, "a_dd < 0 accepted");
    bad = sat_cfg(0);
    bad.a_dq = -1.0;
    FS_CHECK(fs_mag_init(&m, &bad) == FS_ERR_PARAM, "a_dq < 0 accepted");
    bad = sat_cfg(0);
    bad.S = -1.0;
    FS_CHECK(fs_mag_init(&m, &bad) == FS_ERR_PARAM, "S < 0 accepted");

    /* FLUXMAP from the linear model on a 21 x 17 grid. */
    enum { ND = 21, NQ = 17 };
    static double map_d[ND * NQ], map_q[ND * NQ];
    fs_mag_config fc = lc;
    fc.kind = FS_MAG_FLUXMAP;
    fc.map_n_d = ND; fc.map_n_q = NQ;
    fc.map_i_d0 = -50.0; fc.map_di_d = 5.0;
    fc.map_i_q0 = -40.0; fc.map_di_q = 5.0;
    fc.map_psi_d = map_d; fc.map_psi_q = map_q;
    for (int k = 0; k < ND; ++k) {
        for (int l = 0; l < NQ; ++l) {
            double i_d = fc.map_i_d0 + k * fc.map_di_d, i_q = fc.map_i_q0 + l * fc.map_di_q;
            fs_mag_flux(&ml, i_d, i_q, &map_d[k * NQ + l], &map_q[k * NQ + l]);
        }
    }
    fs_mag mf, mf_ref;
    FS_CHECK(fs_mag_init(&mf, &fc) == 0 && fs_mag_init(&mf_ref, &fc) == 0, "fluxmap init");
    FS_CHECK(isnan(fs_mag_energy(&mf, 0.1, 0.0)), "fluxmap energy should be NaN");
    for (double i_d = -70.0; i_d <= 70.0; i_d += 3.3) {      /* beyond the grid too */
        for (double i_q = -60.0; i_q <= 60.0; i_q += 3.7) {
            double pd, pq, a, b;
            fs_mag_flux(&mf_ref, i_d, i_q, &pd, &pq);    /* the map's flux */
            FS_CHECK_REL(pd, 0.1 + 2e-3 * i_d, 1e-12, 1e-14, "fluxmap psi_d of the linear map");
            FS_CHECK_REL(pq, 5e-3 * i_q, 1e-12, 1e-14, "fluxmap psi_q of the linear map");
            fs_mag_current(&mf, pd, pq, &a, &b);          /* mf starts from its last point */
            FS_CHECK_REL(a, i_d, 1e-9, 1e-9, "fluxmap inverse i_d");
            FS_CHECK_REL(b, i_q, 1e-9, 1e-9, "fluxmap inverse i_q");
        }
    }

    /* FLUXMAP tabulated from the saturated model: its own inverse. */
    fs_mag msat;
    fs_mag_config sc = sat_cfg(0);
    fs_mag_init(&msat, &sc);
    for (int k = 0; k < ND; ++k) {
        for (int l = 0; l < NQ; ++l) {
            double i_d = fc.map_i_d0 + k * fc.map_di_d, i_q = fc.map_i_q0 + l * fc.map_di_q;
            fs_mag_flux(&msat, i_d, i_q, &map_d[k * NQ + l], &map_q[k * NQ + l]);
        }
    }
    FS_CHECK(fs_mag_init(&mf, &fc) == 0 && fs_mag_init(&mf_ref, &fc) == 0, "saturated fluxmap init");
    for (double i_d = -48.0; i_d <= 48.0; i_d += 4.1) {
        for (double i_q = -38.0; i_q <= 38.0; i_q += 3.9) {
            double pd, pq, a, b;
            fs_mag_flux(&mf_ref, i_d, i_q, &pd, &pq);
            fs_mag_current(&mf, pd, pq, &a, &b);
            FS_CHECK_REL(a, i_d, 1e-8, 1e-8, "saturated fluxmap inverse i_d");
            FS_CHECK_REL(b, i_q, 1e-8, 1e-8, "saturated fluxmap inverse i_q");
        }
    }
    /* Grid nodes reproduce the model. */
    for (int k = 0; k < ND; k += 4) {
        for (int l = 0; l < NQ; l += 4) {
            double i_d = fc.map_i_d0 + k * fc.map_di_d, i_q = fc.map_i_q0 + l * fc.map_di_q;
            double a, b, c, d;
            fs_mag_flux(&mf_ref, i_d, i_q, &a, &b);
            fs_mag_flux(&msat, i_d, i_q, &c, &d);
            FS_CHECK_NEAR(a, c, 1e-14, "map node psi_d");
            FS_CHECK_NEAR(b, d, 1e-14, "map node psi_q");
        }
    }
    /* invalid maps */
    bad = fc;
    bad.map_n_d = 1;
    FS_CHECK(fs_mag_init(&m, &bad) == FS_ERR_PARAM, "map_n_d = 1 accepted");
    bad = fc;
    bad.map_di_q = 0.0;
    FS_CHECK(fs_mag_init(&m, &bad) == FS_ERR_PARAM, "map_di_q = 0 accepted");
    bad = fc;
    bad.map_psi_q = NULL;
    FS_CHECK(fs_mag_init(&m, &bad) == FS_ERR_NULL, "null map accepted");
    return fs_test_summary("test_magnetic");
}
