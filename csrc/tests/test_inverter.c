/* fs-test-sources: plant/fs_inverter.c plant/fs_losses.c
 *
 * fs_inverter (plant, double): the switching segments of both halves of a
 * carrier period (lengths add to T_pwm/2, states valid, commanded edges where
 * the center-aligned carrier puts them); the period mean of the switching model
 * against the averaged model fs_inverter_mean_voltage: equal within 1e-9
 * without dead time (any currents, with a device drop), and with dead time for
 * a fixed current sign; the dead-time error opposes the current.
 *
 * Five phases (five legs, VSD planes alpha-beta and x-y): the VSD helpers
 * against the definition (fundamental and third-harmonic waves land in their
 * planes, inverse round trip); over random duties and currents the switching
 * model's period mean equals the averaged model in both planes within 1e-9
 * u_dc, with and without dead time and device drop; the phase voltages of
 * every segment sum to zero and are fully carried by (alpha, beta, x, y);
 * at most FS_INV_MAX_SEG segments (all 11 used when the edges are distinct);
 * each leg is high for d T_pwm/2 per half period without dead time; the
 * dead-time error per leg; sinusoidal duties with a third harmonic give the
 * expected voltage in each plane.
 */
#include "plant/fs_inverter.h"
#include "tests/fs_test.h"

static fs_inverter_config cfg(double t_dead, double u_on)
{
    fs_inverter_config c = {0};
    c.kind = FS_INV_SWITCHING;
    c.u_dc = 600.0;
    c.T_pwm = 1e-4;
    c.t_dead = t_dead;
    c.u_on = u_on;
    c.phases = 3;
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
            double a, b, x = 1.0, y = 1.0;
            fs_inverter_voltage(c, seg.state[s], i, &a, &b, &x, &y);
            FS_CHECK(x == 0.0 && y == 0.0, "three phases: x-y voltage (%g, %g) not zero", x, y);
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
    double sa, sb, ma, mb, mx = 1.0, my = 1.0;
    switching_mean(c, duty, i, &sa, &sb);
    fs_inverter_mean_voltage(c, duty, i, &ma, &mb, &mx, &my);
    FS_CHECK(mx == 0.0 && my == 0.0, "three phases: averaged x-y voltage (%g, %g) not zero", mx, my);
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

/* ---- five phases ---------------------------------------------------- */

static fs_inverter_config cfg5(double t_dead, double u_on)
{
    fs_inverter_config c = cfg(t_dead, u_on);
    c.phases = 5;
    return c;
}

/* Reference VSD straight from the definition (library cos and sin). */
static void vsd_ref(const double v[5], double out[5])
{
    const double g = 2.0 * FS_TEST_PI / 5.0;
    for (int n = 0; n < 5; ++n) out[n] = 0.0;
    for (int k = 0; k < 5; ++k) {
        out[0] += 0.4 * v[k] * cos(k * g);
        out[1] += 0.4 * v[k] * sin(k * g);
        out[2] += 0.4 * v[k] * cos(3 * k * g);
        out[3] += 0.4 * v[k] * sin(3 * k * g);
        out[4] += 0.2 * v[k];
    }
}

/* A small reproducible generator (LCG) on [0, 1). */
static double uni(unsigned long long *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*s >> 11) * (1.0 / 9007199254740992.0);
}

/* Mean voltage of both planes over a period from the segments, with the
 * per-segment checks: lengths, states, count, zero-sum phase voltages that the
 * four VSD components carry completely. */
static void switching_mean5(const fs_inverter_config *c, const double duty[5], const double i[5],
                            double u[4])
{
    for (int n = 0; n < 4; ++n) u[n] = 0.0;
    for (int half = 0; half < 2; ++half) {
        fs_inv_segments seg;
        seg.n = -1;
        fs_inverter_segments(c, duty, half, &seg);
        FS_CHECK(seg.n >= 1 && seg.n <= FS_INV_MAX_SEG, "five phases: segment count %d", seg.n);
        if (seg.n < 1 || seg.n > FS_INV_MAX_SEG) return;
        double sum = 0.0;
        for (int s = 0; s < seg.n; ++s) {
            FS_CHECK(seg.dt[s] > 0.0, "five phases: segment %d length %g", s, seg.dt[s]);
            for (int k = 0; k < 5; ++k)
                FS_CHECK(seg.state[s][k] >= -1 && seg.state[s][k] <= 1, "state %d", seg.state[s][k]);
            double a, b, x, y, v[5], ref[5], back[5];
            fs_inverter_voltage(c, seg.state[s], i, &a, &b, &x, &y);
            fs_inverter_phase_voltages(c, seg.state[s], i, v);
            FS_CHECK_NEAR(v[0] + v[1] + v[2] + v[3] + v[4], 0.0, 1e-12 * c->u_dc,
                          "phase voltages sum to zero (no zero sequence)");
            /* each phase voltage is its pole voltage less the mean of the poles */
            double pole[5], mean = 0.0;
            for (int k = 0; k < 5; ++k) {
                int st = seg.state[s][k] < 0 ? i[k] < 0.0 : seg.state[s][k];
                pole[k] = (st ? 0.5 : -0.5) * c->u_dc - (i[k] > 0.0 ? c->u_on : (i[k] < 0.0 ? -c->u_on : 0.0));
                mean += 0.2 * pole[k];
            }
            for (int k = 0; k < 5; ++k) FS_CHECK_NEAR(v[k], pole[k] - mean, 1e-12 * c->u_dc, "phase voltage");
            vsd_ref(v, ref);
            FS_CHECK_NEAR(a, ref[0], 1e-12 * c->u_dc, "segment alpha");
            FS_CHECK_NEAR(b, ref[1], 1e-12 * c->u_dc, "segment beta");
            FS_CHECK_NEAR(x, ref[2], 1e-12 * c->u_dc, "segment x");
            FS_CHECK_NEAR(y, ref[3], 1e-12 * c->u_dc, "segment y");
            fs_inverter_vsd5_inverse(a, b, x, y, 0.0, back);
            for (int k = 0; k < 5; ++k)
                FS_CHECK_NEAR(back[k], v[k], 1e-12 * c->u_dc, "phase voltages from (alpha, beta, x, y)");
            u[0] += a * seg.dt[s];
            u[1] += b * seg.dt[s];
            u[2] += x * seg.dt[s];
            u[3] += y * seg.dt[s];
            sum += seg.dt[s];
        }
        FS_CHECK_NEAR(sum, 0.5 * c->T_pwm, 1e-12 * c->T_pwm, "five phases: half-period length");
    }
    for (int n = 0; n < 4; ++n) u[n] /= c->T_pwm;
}

static void compare5(const fs_inverter_config *c, const double duty[5], const double i[5], double tol_rel,
                     const char *what)
{
    double sw[4], av[4];
    switching_mean5(c, duty, i, sw);
    fs_inverter_mean_voltage(c, duty, i, &av[0], &av[1], &av[2], &av[3]);
    static const char *plane[4] = {"alpha", "beta", "x", "y"};
    for (int n = 0; n < 4; ++n) {
        FS_CHECK(fabs(sw[n] - av[n]) <= tol_rel * c->u_dc,
                 "%s, %s: duties (%g %g %g %g %g), i (%g %g %g %g %g), t_dead %g, u_on %g: switching %.12g, "
                 "averaged %.12g", what, plane[n], duty[0], duty[1], duty[2], duty[3], duty[4], i[0], i[1], i[2],
                 i[3], i[4], c->t_dead, c->u_on, sw[n], av[n]);
    }
}

static double high_time5(const fs_inverter_config *c, const double duty[5], int half, int k)
{
    fs_inv_segments seg;
    fs_inverter_segments(c, duty, half, &seg);
    double t = 0.0;
    for (int s = 0; s < seg.n; ++s) t += seg.state[s][k] == 1 ? seg.dt[s] : 0.0;
    return t;
}

static void five_phase_tests(void)
{
    const double g = 2.0 * FS_TEST_PI / 5.0;

    /* The VSD helpers: against the definition, the inverse, and the waves. */
    {
        unsigned long long rs = 12345;
        for (int n = 0; n < 200; ++n) {
            double v[5], ref[5], o[4], back[5];
            for (int k = 0; k < 5; ++k) v[k] = 200.0 * uni(&rs) - 100.0;
            vsd_ref(v, ref);
            fs_inverter_vsd5(v, &o[0], &o[1], &o[2], &o[3]);
            for (int m = 0; m < 4; ++m) FS_CHECK_NEAR(o[m], ref[m], 1e-12 * 100.0, "fs_inverter_vsd5 vs definition");
            fs_inverter_vsd5_inverse(o[0], o[1], o[2], o[3], ref[4], back);
            for (int k = 0; k < 5; ++k) FS_CHECK_NEAR(back[k], v[k], 1e-12 * 100.0, "fs_inverter_vsd5_inverse round trip");
        }
        for (int n = 0; n < 12; ++n) {
            double th = 0.37 + n * 0.55, v1[5], v3[5], o[4];
            for (int k = 0; k < 5; ++k) {
                v1[k] = cos(th - k * g);
                v3[k] = cos(3.0 * (th - k * g));
            }
            fs_inverter_vsd5(v1, &o[0], &o[1], &o[2], &o[3]);
            FS_CHECK(fabs(o[0] - cos(th)) < 1e-14 && fabs(o[1] - sin(th)) < 1e-14 && fabs(o[2]) < 1e-14
                         && fabs(o[3]) < 1e-14,
                     "fundamental wave at %g -> (%g %g %g %g)", th, o[0], o[1], o[2], o[3]);
            fs_inverter_vsd5(v3, &o[0], &o[1], &o[2], &o[3]);
            FS_CHECK(fabs(o[0]) < 1e-14 && fabs(o[1]) < 1e-14 && fabs(o[2] - cos(3.0 * th)) < 1e-14
                         && fabs(o[3] - sin(3.0 * th)) < 1e-14,
                     "third-harmonic wave at %g -> (%g %g %g %g)", th, o[0], o[1], o[2], o[3]);
        }
    }

    /* Segment structure without dead time: five distinct edges make six
     * segments; each leg is high d T/2 per half; the period starts and ends in
     * the all-low zero vector. With dead time, the ten cuts make eleven. */
    {
        fs_inverter_config c0 = cfg5(0.0, 0.0);
        double d[5] = {0.8, 0.3, 0.55, 0.12, 0.67};
        for (int half = 0; half < 2; ++half) {
            fs_inv_segments seg;
            fs_inverter_segments(&c0, d, half, &seg);
            FS_CHECK_EQ_INT(seg.n, 6, "five phases: segments without dead time (five edges)");
            int first = half == 0 ? 0 : seg.n - 1, mid = half == 0 ? seg.n - 1 : 0;
            for (int k = 0; k < 5; ++k) {
                FS_CHECK(seg.state[first][k] == 0, "five phases: half %d does not start/end at the peak", half);
                FS_CHECK(seg.state[mid][k] == 1, "five phases: half %d valley state", half);
            }
        }
        fs_inverter_config cd = cfg5(2e-6, 0.0);
        fs_inv_segments seg;
        for (int half = 0; half < 2; ++half) {
            fs_inverter_segments(&cd, d, half, &seg);
            FS_CHECK_EQ_INT(seg.n, 11, "five phases: segments with dead time (ten cuts)");
            FS_CHECK(seg.n <= FS_INV_MAX_SEG, "FS_INV_MAX_SEG %d too small", (int)FS_INV_MAX_SEG);
            double dead[5] = {0, 0, 0, 0, 0};
            for (int s = 0; s < seg.n && s < FS_INV_MAX_SEG; ++s)
                for (int k = 0; k < 5; ++k) dead[k] += seg.state[s][k] == -1 ? seg.dt[s] : 0.0;
            for (int k = 0; k < 5; ++k) FS_CHECK_NEAR(dead[k], 2e-6, 1e-15, "five phases: dead interval length");
        }
    }

    /* Random duties and currents: high times, and switching mean = averaged
     * mean in both planes, with and without dead time. */
    {
        unsigned long long rs = 987654321;
        const double t_deads[] = {0.0, 5e-7, 2e-6, 4e-6};
        const double u_ons[] = {0.0, 1.5};
        int max_n = 0;
        for (int trial = 0; trial < 3000; ++trial) {
            double d[5], i[5];
            for (int k = 0; k < 5; ++k) {
                double r = uni(&rs);
                /* mostly interior duties, some at and beyond the ends, some near them */
                if (r < 0.05) d[k] = 0.0;
                else if (r < 0.10) d[k] = 1.0;
                else if (r < 0.13) d[k] = -0.1;
                else if (r < 0.16) d[k] = 1.1;
                else if (r < 0.22) d[k] = 0.03 * uni(&rs);
                else if (r < 0.28) d[k] = 1.0 - 0.03 * uni(&rs);
                else d[k] = uni(&rs);
                i[k] = 20.0 * uni(&rs) - 10.0;
            }
            if (trial % 7 == 0) i[trial % 5] = 0.0;   /* a zero current: no diode, no drop */
            fs_inverter_config c0 = cfg5(0.0, 0.0);
            const double Th = 0.5 * c0.T_pwm;
            for (int half = 0; half < 2; ++half) {
                for (int k = 0; k < 5; ++k) {
                    double dc = d[k] < 0.0 ? 0.0 : (d[k] > 1.0 ? 1.0 : d[k]);
                    FS_CHECK_NEAR(high_time5(&c0, d, half, k), dc * Th, 1e-15, "five phases: high time d T/2");
                }
                fs_inv_segments seg;
                fs_inverter_config c4 = cfg5(4e-6, 0.0);
                fs_inverter_segments(&c4, d, half, &seg);
                if (seg.n > max_n) max_n = seg.n;
            }
            int any_zero = 0;
            for (int k = 0; k < 5; ++k) any_zero |= i[k] == 0.0;
            for (int u = 0; u < 2; ++u) {
                for (int t = 0; t < 4; ++t) {
                    if (t > 0 && any_zero) continue;   /* dead time needs a current sign */
                    fs_inverter_config c = cfg5(t_deads[t], u_ons[u]);
                    compare5(&c, d, i, 1e-9, t == 0 ? "five phases, no dead time" : "five phases, dead time");
                }
            }
        }
        FS_CHECK(max_n <= FS_INV_MAX_SEG, "segments %d", max_n);
        FS_CHECK_EQ_INT(max_n, 11, "the random sweep reaches the most segments");
    }

    /* Dead-time error: each switching pole loses sign(i) t_dead/T u_dc. */
    {
        const double t_dead = 2e-6;
        double d[5] = {0.2, 0.45, 0.9, 0.6, 0.33}, i[5] = {3.0, -1.0, 2.5, -4.0, -0.5};
        fs_inverter_config cz = cfg5(0.0, 0.0), ct = cfg5(t_dead, 0.0);
        double z[4], w[4], v[5], ref[5];
        switching_mean5(&cz, d, i, z);
        switching_mean5(&ct, d, i, w);
        for (int k = 0; k < 5; ++k) v[k] = -(i[k] > 0 ? 1.0 : -1.0) * t_dead / ct.T_pwm * ct.u_dc;
        vsd_ref(v, ref);
        for (int n = 0; n < 4; ++n) FS_CHECK_NEAR(w[n] - z[n], ref[n], 1e-9 * ct.u_dc, "five phases: dead-time error");
    }

    /* Sinusoidal duties with a third harmonic: each plane gets its own wave,
     * amplitude m u_dc/2, at the angle the VSD puts it. */
    {
        fs_inverter_config c = cfg5(0.0, 0.0);
        const double m1 = 0.7, m3 = 0.15, i0[5] = {0, 0, 0, 0, 0};
        for (int n = 0; n < 10; ++n) {
            double th = -2.9 + 0.61 * n, d[5], u[4];
            for (int k = 0; k < 5; ++k) d[k] = 0.5 + 0.5 * m1 * cos(th - k * g) + 0.5 * m3 * cos(3.0 * (th - k * g));
            fs_inverter_mean_voltage(&c, d, i0, &u[0], &u[1], &u[2], &u[3]);
            double want[4] = {0.5 * m1 * c.u_dc * cos(th), 0.5 * m1 * c.u_dc * sin(th),
                              0.5 * m3 * c.u_dc * cos(3.0 * th), 0.5 * m3 * c.u_dc * sin(3.0 * th)};
            for (int m = 0; m < 4; ++m) FS_CHECK_NEAR(u[m], want[m], 1e-12 * c.u_dc, "sinusoidal duties, plane voltage");
            double sw[4];
            switching_mean5(&c, d, i0, sw);
            for (int m = 0; m < 4; ++m) FS_CHECK_NEAR(sw[m], want[m], 1e-9 * c.u_dc, "sinusoidal duties, switching");
        }
    }
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

    five_phase_tests();
    return fs_test_summary("test_inverter");
}
