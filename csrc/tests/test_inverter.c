/* fs-test-sources: plant/fs_inverter.c
 *
 * fs_inverter (plant, double): the switching segments of both halves of a
 * carrier period (lengths add to T_pwm/2, states valid, commanded edges where
 * the center-aligned carrier puts them); the period mean of the switching model
 * against the averaged model fs_inverter_mean_voltage: equal within 1e-9
 * without dead time (any currents, with a device drop), and with dead time for
 * a fixed current sign; the dead-time error opposes the current.
 */
#include "plant/fs_inverter.h"
#include "tests/fs_test.h"

static fs_inverter_config cfg(double t_dead, double u_on)
{
    fs_inverter_config c;
    c.kind = FS_INV_SWITCHING;
    c.u_dc = 600.0;
    c.T_pwm = 1e-4;
    c.t_dead = t_dead;
    c.u_on = u_on;
    return c;
}

/* Mean stationary voltage over a period from the segments. */
static void switching_mean(const fs_inverter_config *c, const double duty[3], const double i[3], double *ua,
                           double *ub)
{
    *ua = *ub = 0.0;
    for (int half = 0; half < 2; ++half) {
        fs_inv_segments seg;
        seg.n = -1;
        fs_inverter_segments(c, duty, half, &seg);
        FS_CHECK(seg.n >= 1 && seg.n <= FS_INV_MAX_SEG, "segment count %d", seg.n);
        if (seg.n < 1 || seg.n > FS_INV_MAX_SEG) return;
        double sum = 0.0;
        for (int s = 0; s < seg.n; ++s) {
            FS_CHECK(seg.dt[s] > 0.0, "segment %d length %g", s, seg.dt[s]);
            for (int k = 0; k < 3; ++k) {
                FS_CHECK(seg.state[s][k] >= -1 && seg.state[s][k] <= 1, "state %d", seg.state[s][k]);
            }
            double a, b;
            fs_inverter_voltage(c, seg.state[s], i, &a, &b);
            *ua += a * seg.dt[s];
            *ub += b * seg.dt[s];
            sum += seg.dt[s];
        }
        FS_CHECK_NEAR(sum, 0.5 * c->T_pwm, 1e-12 * c->T_pwm, "half-period length");
    }
    *ua /= c->T_pwm;
    *ub /= c->T_pwm;
}

static void compare(const fs_inverter_config *c, const double duty[3], const double i[3], double tol_rel,
                    const char *what)
{
    double sa, sb, ma, mb;
    switching_mean(c, duty, i, &sa, &sb);
    fs_inverter_mean_voltage(c, duty, i, &ma, &mb);
    FS_CHECK(fabs(sa - ma) <= tol_rel * c->u_dc && fabs(sb - mb) <= tol_rel * c->u_dc,
             "%s: duties (%g %g %g), i (%g %g %g): switching (%.12g, %.12g), averaged (%.12g, %.12g)", what,
             duty[0], duty[1], duty[2], i[0], i[1], i[2], sa, sb, ma, mb);
}

/* Time within half `half` at which phase k is high, from the segments. */
static double high_time(const fs_inverter_config *c, const double duty[3], int half, int k)
{
    fs_inv_segments seg;
    fs_inverter_segments(c, duty, half, &seg);
    double t = 0.0;
    for (int s = 0; s < seg.n; ++s) t += seg.state[s][k] == 1 ? seg.dt[s] : 0.0;
    return t;
}

int main(void)
{
    /* Segment structure, zero dead time: the pole is high for d T_pwm/2 in each
     * half, at the end of the falling half and the start of the rising half. */
    fs_inverter_config c0 = cfg(0.0, 0.0);
    const double Th = 0.5 * c0.T_pwm;
    double duty[3] = {0.8, 0.3, 0.55};
    for (int half = 0; half < 2; ++half) {
        fs_inv_segments seg;
        fs_inverter_segments(&c0, duty, half, &seg);
        FS_CHECK_EQ_INT(seg.n, 4, "segments without dead time (three edges)");
        for (int k = 0; k < 3; ++k) {
            FS_CHECK_NEAR(high_time(&c0, duty, half, k), duty[k] * Th, 1e-15, "high time d T/2");
        }
        /* The period starts and ends at the carrier peak in the zero vector (all
         * low); at the valley, mid-period, every pole with d > 0 is high. */
        int first = half == 0 ? 0 : seg.n - 1;
        for (int k = 0; k < 3; ++k) {
            FS_CHECK(seg.state[first][k] == 0, "half %d: the period does not start/end at the peak zero vector",
                     half);
        }
        int mid = half == 0 ? seg.n - 1 : 0;
        for (int k = 0; k < 3; ++k) FS_CHECK(seg.state[mid][k] == 1, "half %d: valley state", half);
    }
    /* Falling half: edge of phase 0 (d = 0.8) at (1 - d) T/2. */
    {
        fs_inv_segments seg;
        fs_inverter_segments(&c0, duty, 0, &seg);
        FS_CHECK_NEAR(seg.dt[0], (1.0 - 0.8) * Th, 1e-15, "first edge of the falling half");
        fs_inverter_segments(&c0, duty, 1, &seg);
        FS_CHECK_NEAR(seg.dt[0], 0.3 * Th, 1e-15, "first edge of the rising half");
    }
    /* Dead time: 7 segments at most, dead intervals of t_dead after each edge. */
    {
        fs_inverter_config cd = cfg(2e-6, 0.0);
        fs_inv_segments seg;
        fs_inverter_segments(&cd, duty, 0, &seg);
        FS_CHECK_EQ_INT(seg.n, 7, "segments with dead time");
        double dead[3] = {0, 0, 0};
        for (int s = 0; s < seg.n; ++s)
            for (int k = 0; k < 3; ++k) dead[k] += seg.state[s][k] == -1 ? seg.dt[s] : 0.0;
        for (int k = 0; k < 3; ++k) FS_CHECK_NEAR(dead[k], 2e-6, 1e-15, "dead interval length");
    }

    /* Sweep: lengths, and switching mean = averaged model. */
    const double ds[] = {0.0, 1e-3, 0.01, 0.02, 0.05, 0.1, 0.25, 0.333, 0.5, 0.6, 0.75, 0.9, 0.95, 0.98, 0.99,
                         0.999, 1.0};
    const int nd = (int)(sizeof ds / sizeof ds[0]);
    const double currents[][3] = {{5.0, -2.0, -3.0}, {-4.0, 1.0, 3.0}, {2.0, 2.0, -4.0}, {-1e-3, -7.0, 7.001},
                                  {0.0, 0.0, 0.0}, {10.0, -10.0, 0.0}};
    const double t_deads[] = {0.0, 5e-7, 2e-6, 4e-6};
    const double u_ons[] = {0.0, 1.5};
    for (int a = 0; a < nd; ++a) {
        for (int b = 0; b < nd; b += 2) {
            for (int e = 1; e < nd; e += 3) {
                double d[3] = {ds[a], ds[b], ds[e]};
                for (int n = 0; n < 6; ++n) {
                    for (int u = 0; u < 2; ++u) {
                        /* No dead time: any current (also zero) */
                        fs_inverter_config cz = cfg(0.0, u_ons[u]);
                        compare(&cz, d, currents[n], 1e-9, "no dead time");
                        /* Dead time with a definite current sign per phase */
                        if (currents[n][0] == 0.0 || currents[n][1] == 0.0 || currents[n][2] == 0.0) continue;
                        for (int t = 1; t < 4; ++t) {
                            fs_inverter_config ct = cfg(t_deads[t], u_ons[u]);
                            compare(&ct, d, currents[n], 1e-9, "dead time");
                        }
                    }
                }
            }
        }
    }

    /* Dead-time error: for duties away from 0 and 1 each pole loses
     * sign(i) t_dead / T_pwm u_dc, so the error vector opposes the current:
     *   du = clarke(-sign(i) t_dead/T u_dc),  du . i < 0. */
    const double t_dead = 2e-6;  /* d T_pwm/2 and (1 - d) T_pwm/2 exceed it for d in [0.05, 0.95] */
    const double dm[] = {0.05, 0.1, 0.25, 0.333, 0.5, 0.6, 0.75, 0.9, 0.95};
    for (int a = 0; a < 9; ++a) {
        for (int n = 0; n < 4; ++n) {
            double d[3] = {dm[a], dm[(a + 4) % 9], dm[(a + 7) % 9]};
            const double *i = currents[n];
            fs_inverter_config cz = cfg(0.0, 0.0), ct = cfg(t_dead, 0.0);
            double za, zb, ta, tb;
            switching_mean(&cz, d, i, &za, &zb);
            switching_mean(&ct, d, i, &ta, &tb);
            double e = t_dead / ct.T_pwm * ct.u_dc, v[3];
            for (int k = 0; k < 3; ++k) v[k] = -(i[k] > 0 ? 1.0 : -1.0) * e;
            double wa = (2 * v[0] - v[1] - v[2]) / 3.0, wb = (v[1] - v[2]) / sqrt(3.0);
            FS_CHECK_NEAR(ta - za, wa, 1e-9 * ct.u_dc, "dead-time error alpha");
            FS_CHECK_NEAR(tb - zb, wb, 1e-9 * ct.u_dc, "dead-time error beta");
            double ia = (2 * i[0] - i[1] - i[2]) / 3.0, ib = (i[1] - i[2]) / sqrt(3.0);
            FS_CHECK((ta - za) * ia + (tb - zb) * ib < 0.0, "dead-time error does not oppose the current");
            /* Per phase: the high time of each pole shrinks for i > 0, grows for i < 0. */
            for (int k = 0; k < 3; ++k) {
                double hz = 0, ht = 0;
                for (int half = 0; half < 2; ++half) {
                    hz += high_time(&cz, d, half, k);
                    fs_inv_segments seg;
                    fs_inverter_segments(&ct, d, half, &seg);
                    for (int s = 0; s < seg.n; ++s) {
                        int st = seg.state[s][k];
                        if (st < 0) st = i[k] < 0.0;  /* the diode that conducts */
                        ht += st == 1 ? seg.dt[s] : 0.0;
                    }
                }
                double want = i[k] > 0 ? -t_dead : t_dead;
                FS_CHECK_NEAR(ht - hz, want, 1e-15, "per-phase dead-time volt-seconds");
            }
        }
    }

    /* Duties outside [0, 1] act as 0 and 1 in both models. */
    double dclip[3] = {-0.2, 1.3, 0.5}, dref[3] = {0.0, 1.0, 0.5}, ipos[3] = {1.0, 1.0, -2.0};
    fs_inverter_config ct = cfg(2e-6, 1.0);
    double a1, b1, a2, b2;
    switching_mean(&ct, dclip, ipos, &a1, &b1);
    switching_mean(&ct, dref, ipos, &a2, &b2);
    FS_CHECK_NEAR(a1, a2, 1e-12, "clipped duties alpha");
    FS_CHECK_NEAR(b1, b2, 1e-12, "clipped duties beta");
    compare(&ct, dclip, ipos, 1e-9, "clipped duties");
    return fs_test_summary("test_inverter");
}
