/* fs-test-sources: plant/fs_pmsm.c plant/fs_magnetic.c plant/fs_inverter.c plant/fs_losses.c
 *
 * fs_pmsm with five phases (plant, double): the third-harmonic plane d3-q3 of
 * Yu, Wang, Li, Energies 2022, eq. (1), beside the fundamental one.
 *  - configuration: phases 3 or 5, L_d3, L_q3 > 0 and psi_f3 >= 0 for five;
 *    the initial state has psi_d3 = psi_f3, psi_q3 = 0;
 *  - outputs: i_d3 = (psi_d3 - psi_f3)/L_d3, i_q3 = psi_q3/L_q3 and
 *    T_e = 5/2 p [psi_d i_q - psi_q i_d + 3 (psi_d3 i_q3 - psi_q3 i_d3)];
 *    fs_pmsm_energy = 5/2 (W + W3);
 *  - power balance: a balanced five-phase sinusoidal voltage plus a
 *    third-harmonic one (phase voltages turned into alpha-beta and x-y with
 *    fs_inverter_vsd5), held over small RK4 steps, on a free frictionless shaft:
 *    E_in - E_cu - E_airgap = change of 5/2 (W + W3) to 1e-9 of E_in, the
 *    air-gap work equals the kinetic energy, and the third-harmonic plane
 *    carries power (its copper loss is a visible part of E_cu);
 *  - the steady state of eq. (1) at a held speed with zero x-y voltage: the
 *    magnet's third harmonic drives i_d3, i_q3 = the solution of the 2 x 2
 *    system with p = 0, magnitude 3 w_e psi_f3 / |R + j 3 w_e L| for
 *    L_d3 = L_q3, within 1 % (here far closer); likewise with a
 *    third-harmonic phase voltage turning with the rotor (constant u_d3, u_q3);
 *  - the planes are decoupled: with psi_f3 = 0 and no x-y voltage the five-
 *    phase fundamental trajectory is the three-phase one, bit for bit, the
 *    d3-q3 states stay at rest, and E_in is 5/3 of the three-phase one;
 *  - a three-phase machine does not touch the two extra states.
 */
#include <string.h>

#include "plant/fs_inverter.h"
#include "plant/fs_pmsm.h"
#include "tests/fs_test.h"

/* yu2022: 9 pole pairs, R 0.5, L_d 11.8 mH, L_q 13.7 mH, psi_f 0.098 Wb,
 * third harmonic L_d3 3.54 mH, L_q3 4.11 mH, psi_f3 2 mWb (chosen). */
static fs_pmsm_config yu(int phases)
{
    fs_pmsm_config c;
    memset(&c, 0, sizeof c);
    c.pole_pairs = 9;
    c.R_s = 0.5;
    c.mag.kind = FS_MAG_LINEAR;
    c.mag.L_d = 11.8e-3;
    c.mag.L_q = 13.7e-3;
    c.mag.psi_f = 0.098;
    c.J = 0.005;
    c.load_kind = FS_LOAD_TORQUE;
    c.phases = phases;
    c.L_d3 = 3.54e-3;
    c.L_q3 = 4.11e-3;
    c.psi_f3 = 0.002;
    return c;
}

static double energy_ref(const fs_pmsm_config *c, const double *x)
{
    double dd = x[FS_X_PSI_D] - c->mag.psi_f, qq = x[FS_X_PSI_Q];
    double d3 = x[FS_X_PSI_D3] - c->psi_f3, q3 = x[FS_X_PSI_Q3];
    return 2.5 * (dd * dd / (2.0 * c->mag.L_d) + qq * qq / (2.0 * c->mag.L_q) + d3 * d3 / (2.0 * c->L_d3)
                  + q3 * q3 / (2.0 * c->L_q3));
}

static void test_config(void)
{
    fs_pmsm m;
    fs_pmsm_config c = yu(5);
    FS_CHECK_EQ_INT(fs_pmsm_init(&m, &c), 0, "five-phase yu2022 accepted");
    c.phases = 4;
    FS_CHECK_EQ_INT(fs_pmsm_init(&m, &c), FS_ERR_PARAM, "phases = 4 refused");
    c.phases = 0;
    FS_CHECK_EQ_INT(fs_pmsm_init(&m, &c), FS_ERR_PARAM, "phases = 0 refused");
    c = yu(5);
    c.L_d3 = 0.0;
    FS_CHECK_EQ_INT(fs_pmsm_init(&m, &c), FS_ERR_LD, "L_d3 = 0 refused");
    c = yu(5);
    c.L_q3 = -1e-3;
    FS_CHECK_EQ_INT(fs_pmsm_init(&m, &c), FS_ERR_LQ, "L_q3 < 0 refused");
    c = yu(5);
    c.psi_f3 = -1e-3;
    FS_CHECK_EQ_INT(fs_pmsm_init(&m, &c), FS_ERR_PSI_F, "psi_f3 < 0 refused");
    c = yu(5);
    c.psi_f3 = NAN;
    FS_CHECK_EQ_INT(fs_pmsm_init(&m, &c), FS_ERR_PSI_F, "psi_f3 NaN refused");
    c = yu(3);
    c.L_d3 = c.L_q3 = 0.0;
    c.psi_f3 = -1.0;
    FS_CHECK_EQ_INT(fs_pmsm_init(&m, &c), 0, "three phases ignore the third-harmonic parameters");

    c = yu(5);
    fs_pmsm_init(&m, &c);
    double x[FS_X_N];
    for (int n = 0; n < FS_X_N; ++n) x[n] = 123.0;
    fs_pmsm_initial_state(&m, x);
    FS_CHECK_NEAR(x[FS_X_PSI_D], c.mag.psi_f, 1e-15, "initial psi_d");
    FS_CHECK_NEAR(x[FS_X_PSI_D3], c.psi_f3, 1e-15, "initial psi_d3 = psi_f3");
    for (int n = 0; n < FS_X_N; ++n) {
        if (n != FS_X_PSI_D && n != FS_X_PSI_D3) FS_CHECK(x[n] == 0.0, "initial state %d = %g", n, x[n]);
    }
    double i_d3 = 1.0, i_q3 = 1.0;
    fs_pmsm_currents3(&m, x, &i_d3, &i_q3);
    FS_CHECK(i_d3 == 0.0 && i_q3 == 0.0, "no third-harmonic current at rest: %g %g", i_d3, i_q3);
    FS_CHECK_NEAR(fs_pmsm_energy(&m, x), 0.0, 1e-18, "no stored energy at rest");
}

static void test_outputs(void)
{
    fs_pmsm m;
    fs_pmsm_config c = yu(5);
    fs_pmsm_init(&m, &c);
    double x[FS_X_N];
    fs_pmsm_initial_state(&m, x);
    x[FS_X_PSI_D] = 0.09;
    x[FS_X_PSI_Q] = 0.05;
    x[FS_X_PSI_D3] = 0.0035;
    x[FS_X_PSI_Q3] = -0.004;
    fs_pmsm_input in;
    memset(&in, 0, sizeof in);
    double i_d, i_q, T_e, T_s, i_d3, i_q3;
    fs_pmsm_outputs(&m, x, &in, &i_d, &i_q, &T_e, &T_s);
    fs_pmsm_currents3(&m, x, &i_d3, &i_q3);
    double id = (0.09 - c.mag.psi_f) / c.mag.L_d, iq = 0.05 / c.mag.L_q;
    double id3 = (0.0035 - c.psi_f3) / c.L_d3, iq3 = -0.004 / c.L_q3;
    FS_CHECK_REL(i_d, id, 1e-12, 0.0, "i_d");
    FS_CHECK_REL(i_q, iq, 1e-12, 0.0, "i_q");
    FS_CHECK_REL(i_d3, id3, 1e-12, 0.0, "i_d3 = (psi_d3 - psi_f3)/L_d3");
    FS_CHECK_REL(i_q3, iq3, 1e-12, 0.0, "i_q3 = psi_q3/L_q3");
    double T = 2.5 * 9 * (0.09 * iq - 0.05 * id + 3.0 * (0.0035 * iq3 - (-0.004) * id3));
    FS_CHECK_REL(T_e, T, 1e-12, 0.0, "T_e = 5/2 p [psi_d i_q - psi_q i_d + 3 (psi_d3 i_q3 - psi_q3 i_d3)]");
    FS_CHECK_REL(fs_pmsm_energy(&m, x), energy_ref(&c, x), 1e-12, 0.0, "energy 5/2 (W + W3)");

    /* three phases: the same fundamental torque with 3/2, no third harmonic */
    fs_pmsm m3;
    fs_pmsm_config c3 = yu(3);
    fs_pmsm_init(&m3, &c3);
    fs_pmsm_outputs(&m3, x, &in, &i_d, &i_q, &T_e, &T_s);
    FS_CHECK_REL(T_e, 1.5 * 9 * (0.09 * iq - 0.05 * id), 1e-12, 0.0, "three-phase torque");
    fs_pmsm_currents3(&m3, x, &i_d3, &i_q3);
    FS_CHECK(i_d3 == 0.0 && i_q3 == 0.0, "three phases: no third-harmonic current");
}

/* Phase voltages u_k = U1 cos(w t - k g) + U3 cos(3 (w t - k g) + phi3) into
 * the held input's two planes. */
static void five_phase_voltage(double U1, double U3, double phi3, double wt, fs_pmsm_input *in)
{
    const double g = 2.0 * FS_TEST_PI / 5.0;
    double v[5];
    for (int k = 0; k < 5; ++k) v[k] = U1 * cos(wt - k * g) + U3 * cos(3.0 * (wt - k * g) + phi3);
    fs_inverter_vsd5(v, &in->u_alpha, &in->u_beta, &in->u_x, &in->u_y);
}

static void test_power_balance(void)
{
    fs_pmsm m;
    fs_pmsm_config c = yu(5);
    FS_CHECK_EQ_INT(fs_pmsm_init(&m, &c), 0, "init");
    double x[FS_X_N];
    fs_pmsm_initial_state(&m, x);
    x[FS_X_THETA_M] = 0.3;
    const double W0 = fs_pmsm_energy(&m, x), w0 = x[FS_X_W_M];
    fs_pmsm_input in;
    memset(&in, 0, sizeof in);
    /* a ramping frequency so that the rotor (pulled along) and the voltage
     * both turn; 40 V fundamental, 15 V third harmonic */
    const double h = 2e-6, T_end = 0.08;
    const int steps = (int)(T_end / h + 0.5);
    double wt = 0.0, w = 0.0;
    double ecu3 = 0.0;   /* third-harmonic copper loss, by the trapezoidal rule (check only) */
    double i_d3, i_q3, prev = 0.0;
    for (int n = 0; n < steps; ++n) {
        double t = n * h;
        w = 2000.0 * t;   /* el. rad/s, up to 160 */
        wt += w * h;
        five_phase_voltage(20.0 + 250.0 * t, 15.0, 0.4, wt, &in);
        fs_pmsm_rk4(&m, x, &in, h);
        fs_pmsm_currents3(&m, x, &i_d3, &i_q3);
        double p3 = 2.5 * c.R_s * (i_d3 * i_d3 + i_q3 * i_q3);
        ecu3 += 0.5 * h * (p3 + prev);
        prev = p3;
    }
    double E_in = x[FS_X_E_IN], E_cu = x[FS_X_E_CU], E_ag = x[FS_X_E_AIRGAP];
    double dW = fs_pmsm_energy(&m, x) - W0;
    FS_CHECK(E_in > 1.0, "a meaningful input energy: %g J", E_in);
    FS_CHECK_NEAR(E_in - E_cu - E_ag, dW, 1e-9 * E_in, "E_in - E_cu - E_airgap = change of 5/2 (W + W3)");
    FS_CHECK_NEAR(fs_pmsm_energy(&m, x), energy_ref(&c, x), 1e-12, "fs_pmsm_energy against 5/2 (W + W3)");
    double KE = 0.5 * c.J * (x[FS_X_W_M] * x[FS_X_W_M] - w0 * w0);
    FS_CHECK(fabs(x[FS_X_W_M]) > 1.0, "the rotor turns: %g rad/s", x[FS_X_W_M]);
    FS_CHECK_NEAR(E_ag, KE, 1e-9 * E_in, "air-gap work = kinetic energy (free, frictionless shaft)");
    FS_CHECK(ecu3 > 0.01 * E_cu, "the third-harmonic plane carries power: %g of %g J copper loss", ecu3, E_cu);
    printf("power balance: E_in %.6f J, E_cu %.6f J (third harmonic %.6f J), E_airgap %.6f J, dW %.6f J, "
           "residual %.3g J\n", E_in, E_cu, ecu3, E_ag, dW, E_in - E_cu - E_ag - dW);
}

/* Steady state of eq. (1) with p = 0 and u_d3 = u_q3 = 0:
 *   0 = R i_d3 - 3 w L_q3 i_q3,   0 = R i_q3 + 3 w L_d3 i_d3 + 3 w psi_f3. */
static void steady3(double R, double L_d3, double L_q3, double psi_f3, double w_e, double *i_d3, double *i_q3)
{
    double a = R, b = -3.0 * w_e * L_q3, cc = 3.0 * w_e * L_d3, d = R;
    double r1 = 0.0, r2 = -3.0 * w_e * psi_f3;
    double det = a * d - b * cc;
    *i_d3 = (r1 * d - b * r2) / det;
    *i_q3 = (a * r2 - cc * r1) / det;
}

static void test_steady_state(double L_d3, double L_q3, double rpm)
{
    fs_pmsm m;
    fs_pmsm_config c = yu(5);
    c.L_d3 = L_d3;
    c.L_q3 = L_q3;
    c.psi_f3 = 0.02;   /* ten times yu2022's, for a clear current */
    c.load_kind = FS_LOAD_SPEED_IDEAL;
    FS_CHECK_EQ_INT(fs_pmsm_init(&m, &c), 0, "init");
    double x[FS_X_N];
    fs_pmsm_initial_state(&m, x);
    const double w_m = rpm * 2.0 * FS_TEST_PI / 60.0, w_e = c.pole_pairs * w_m;
    x[FS_X_W_M] = w_m;
    x[FS_X_THETA_M] = 0.1;
    fs_pmsm_input in;
    memset(&in, 0, sizeof in);   /* no voltage in either plane, dw_load = 0 */
    /* 40 time constants L/R of the third-harmonic plane */
    const double tau = (L_d3 > L_q3 ? L_d3 : L_q3) / c.R_s;
    const double h = fmin(2e-6, 0.02 / (3.0 * w_e));
    const int steps = (int)(40.0 * tau / h);
    for (int n = 0; n < steps; ++n) fs_pmsm_rk4(&m, x, &in, h);
    double i_d3, i_q3, e_d3, e_q3;
    fs_pmsm_currents3(&m, x, &i_d3, &i_q3);
    steady3(c.R_s, L_d3, L_q3, c.psi_f3, w_e, &e_d3, &e_q3);
    double mag = hypot(e_d3, e_q3);
    FS_CHECK(mag > 0.05, "a meaningful third-harmonic current: %g A", mag);
    FS_CHECK_NEAR(i_d3, e_d3, 0.01 * mag, "steady i_d3 of eq. (1)");
    FS_CHECK_NEAR(i_q3, e_q3, 0.01 * mag, "steady i_q3 of eq. (1)");
    FS_CHECK_NEAR(hypot(i_d3, i_q3), mag, 0.01 * mag, "steady third-harmonic current magnitude");
    if (L_d3 == L_q3) {
        double phasor = 3.0 * w_e * c.psi_f3 / hypot(c.R_s, 3.0 * w_e * L_d3);
        FS_CHECK_NEAR(hypot(i_d3, i_q3), phasor, 0.01 * phasor, "|I| = 3 w psi_f3 / |R + j 3 w L|");
    }
    printf("steady state at %g rpm, L_d3 %g, L_q3 %g: i_d3 %.6f (eq. (1): %.6f), i_q3 %.6f (%.6f) A\n", rpm, L_d3,
           L_q3, i_d3, e_d3, i_q3, e_q3);
}

/* A third-harmonic phase voltage U3 cos(3 (theta_e - k g) + phi) turning with
 * the rotor is u_d3 + j u_q3 = U3 e^(j phi) in d3-q3: the steady currents
 * solve eq. (1) with p = 0,
 *   u_d3 = R i_d3 - 3 w L_q3 i_q3,  u_q3 = R i_q3 + 3 w L_d3 i_d3 + 3 w psi_f3. */
static void test_steady_state_voltage(double U3, double phi, double rpm)
{
    fs_pmsm m;
    fs_pmsm_config c = yu(5);
    c.load_kind = FS_LOAD_SPEED_IDEAL;
    FS_CHECK_EQ_INT(fs_pmsm_init(&m, &c), 0, "init");
    double x[FS_X_N];
    fs_pmsm_initial_state(&m, x);
    const double w_m = rpm * 2.0 * FS_TEST_PI / 60.0, w_e = c.pole_pairs * w_m;
    x[FS_X_W_M] = w_m;
    x[FS_X_THETA_M] = -0.2;
    fs_pmsm_input in;
    memset(&in, 0, sizeof in);
    const double tau = c.L_q3 / c.R_s, h = fmin(2e-6, 0.02 / (3.0 * w_e));
    const int steps = (int)(40.0 * tau / h);
    const double g = 2.0 * FS_TEST_PI / 5.0;
    for (int n = 0; n < steps; ++n) {
        /* the voltage at the step's midpoint angle, held over the step */
        double th = c.pole_pairs * (x[FS_X_THETA_M] + 0.5 * h * w_m), v[5];
        for (int k = 0; k < 5; ++k) v[k] = U3 * cos(3.0 * (th - k * g) + phi);
        fs_inverter_vsd5(v, &in.u_alpha, &in.u_beta, &in.u_x, &in.u_y);
        fs_pmsm_rk4(&m, x, &in, h);
    }
    double u_d3 = U3 * cos(phi), u_q3 = U3 * sin(phi) - 3.0 * w_e * c.psi_f3;
    double a = c.R_s, b = -3.0 * w_e * c.L_q3, cc = 3.0 * w_e * c.L_d3, det = a * a - b * cc;
    double e_d3 = (u_d3 * a - b * u_q3) / det, e_q3 = (a * u_q3 - cc * u_d3) / det;
    double i_d3, i_q3, mag = hypot(e_d3, e_q3);
    fs_pmsm_currents3(&m, x, &i_d3, &i_q3);
    FS_CHECK(mag > 0.1, "a meaningful third-harmonic current: %g A", mag);
    FS_CHECK_NEAR(i_d3, e_d3, 0.01 * mag, "steady i_d3 with a third-harmonic voltage");
    FS_CHECK_NEAR(i_q3, e_q3, 0.01 * mag, "steady i_q3 with a third-harmonic voltage");
    printf("steady state with U3 %g V at %g rad, %g rpm: i_d3 %.6f (eq. (1): %.6f), i_q3 %.6f (%.6f) A\n", U3, phi,
           rpm, i_d3, e_d3, i_q3, e_q3);
}

static void test_planes_decoupled(void)
{
    fs_pmsm m3, m5;
    fs_pmsm_config c3 = yu(3), c5 = yu(5);
    c3.load_kind = c5.load_kind = FS_LOAD_SPEED_IDEAL;
    c5.psi_f3 = 0.0;
    fs_pmsm_init(&m3, &c3);
    fs_pmsm_init(&m5, &c5);
    double x3[FS_X_N], x5[FS_X_N];
    fs_pmsm_initial_state(&m3, x3);
    fs_pmsm_initial_state(&m5, x5);
    x3[FS_X_PSI_D3] = 7.25;   /* a three-phase step must not touch them */
    x3[FS_X_PSI_Q3] = -3.5;
    x3[FS_X_W_M] = x5[FS_X_W_M] = 50.0;
    fs_pmsm_input in;
    memset(&in, 0, sizeof in);
    in.dw_load = 100.0;
    const double h = 5e-6;
    for (int n = 0; n < 4000; ++n) {
        double th = 450.0 * n * h;
        in.u_alpha = 30.0 * cos(th);
        in.u_beta = 30.0 * sin(th);
        in.u_x = in.u_y = 0.0;
        fs_pmsm_rk4(&m3, x3, &in, h);
        fs_pmsm_rk4(&m5, x5, &in, h);
    }
    const int same[] = {FS_X_PSI_D, FS_X_PSI_Q, FS_X_W_M, FS_X_THETA_M, FS_X_UD_INT, FS_X_UQ_INT};
    for (int n = 0; n < 6; ++n)
        FS_CHECK(x3[same[n]] == x5[same[n]], "state %d: three phases %.17g, five %.17g", same[n], x3[same[n]],
                 x5[same[n]]);
    FS_CHECK(x5[FS_X_PSI_D3] == 0.0 && x5[FS_X_PSI_Q3] == 0.0, "d3-q3 at rest without psi_f3 and x-y voltage");
    FS_CHECK(x3[FS_X_PSI_D3] == 7.25 && x3[FS_X_PSI_Q3] == -3.5, "a three-phase step touched the d3-q3 states");
    FS_CHECK_REL(x5[FS_X_E_IN], 5.0 / 3.0 * x3[FS_X_E_IN], 1e-12, 0.0, "E_in scales with m/2");
    FS_CHECK_REL(x5[FS_X_E_CU], 5.0 / 3.0 * x3[FS_X_E_CU], 1e-12, 0.0, "E_cu scales with m/2");

    /* a three-phase machine ignores u_x, u_y */
    double xa[FS_X_N], xb[FS_X_N];
    fs_pmsm_initial_state(&m3, xa);
    fs_pmsm_initial_state(&m3, xb);
    xa[FS_X_W_M] = xb[FS_X_W_M] = 30.0;
    in.u_alpha = 10.0;
    in.u_beta = -5.0;
    in.u_x = in.u_y = 0.0;
    fs_pmsm_rk4(&m3, xa, &in, h);
    in.u_x = 50.0;
    in.u_y = -20.0;
    fs_pmsm_rk4(&m3, xb, &in, h);
    for (int n = 0; n < FS_X_N3; ++n) FS_CHECK(xa[n] == xb[n], "three phases: u_x, u_y changed state %d", n);
}

int main(void)
{
    test_config();
    test_outputs();
    test_power_balance();
    test_steady_state(3.54e-3, 3.54e-3, 1500.0);
    test_steady_state(3.54e-3, 4.11e-3, 1500.0);
    test_steady_state(3.54e-3, 4.11e-3, 50.0);
    test_steady_state(6.0e-3, 2.0e-3, 300.0);
    test_steady_state_voltage(10.0, 0.7, 600.0);
    test_steady_state_voltage(25.0, -2.0, 100.0);
    test_planes_decoupled();
    return fs_test_summary("test_pmsm5");
}
