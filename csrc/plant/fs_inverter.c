#include "fs_inverter.h"

#include <math.h>

/* cos and sin of 2 pi/5 and 4 pi/5 */
#define C1 0.30901699437494742410
#define C2 (-0.80901699437494742410)
#define S1 0.95105651629515357212
#define S2 0.58778525229247312917

/* cos(k g), sin(k g), cos(3 k g), sin(3 k g), g = 2 pi/5 (3 k g = (3k mod 5) g) */
static const double COS1[5] = {1.0, C1, C2, C2, C1};
static const double SIN1[5] = {0.0, S1, S2, -S2, -S1};
static const double COS3[5] = {1.0, C2, C1, C1, C2};
static const double SIN3[5] = {0.0, -S2, S1, -S1, S2};

static double sgn(double x) { return (x > 0.0) - (x < 0.0); }

static int legs(const fs_inverter_config *c) { return c->phases == 5 ? 5 : 3; }

static void clarke(const double v[3], double *a, double *b)
{
    *a = (2.0 * v[0] - v[1] - v[2]) / 3.0;
    *b = (v[1] - v[2]) / sqrt(3.0);
}

void fs_inverter_vsd5(const double v[5], double *alpha, double *beta, double *x, double *y)
{
    double a = 0.0, b = 0.0, p = 0.0, q = 0.0;
    for (int k = 0; k < 5; ++k) {
        a += v[k] * COS1[k];
        b += v[k] * SIN1[k];
        p += v[k] * COS3[k];
        q += v[k] * SIN3[k];
    }
    *alpha = 0.4 * a;
    *beta = 0.4 * b;
    *x = 0.4 * p;
    *y = 0.4 * q;
}

fs_status fs_inverter_check(const fs_inverter_config *c)
{
    if (!c) return FS_ERR_NULL;
    if (c->kind != FS_INV_AVERAGED && c->kind != FS_INV_SWITCHING) return FS_ERR_MODE;
    if (!(c->u_dc > 0.0) || !isfinite(c->u_dc)) return FS_ERR_LIMIT;
    if (!(c->T_pwm > 0.0) || !isfinite(c->T_pwm)) return FS_ERR_TS;
    if (!(c->t_dead >= 0.0 && c->t_dead < 0.5 * c->T_pwm)) return FS_ERR_PARAM;
    if (!(c->u_on >= 0.0) || !isfinite(c->u_on)) return FS_ERR_PARAM;
    if (!(c->r_on >= 0.0) || !isfinite(c->r_on)) return FS_ERR_PARAM;
    if (fs_device_check(&c->dev) != FS_OK) return FS_ERR_PARAM;
    if (c->dev.enabled && (c->u_on != 0.0 || c->r_on != 0.0)) return FS_ERR_PARAM;
    return c->phases == 3 || c->phases == 5 ? FS_OK : FS_ERR_PARAM;
}

void fs_inverter_vsd5_inverse(double alpha, double beta, double x, double y, double zero, double v[5])
{
    for (int k = 0; k < 5; ++k)
        v[k] = alpha * COS1[k] + beta * SIN1[k] + x * COS3[k] + y * SIN3[k] + zero;
}

void fs_inverter_segments(const fs_inverter_config *c, const double *duty, int half,
                          fs_inv_segments *seg)
{
    const int nl = legs(c);
    const double Th = 0.5 * c->T_pwm;
    double edge[FS_INV_MAX_LEGS], dead_end[FS_INV_MAX_LEGS];
    int before[FS_INV_MAX_LEGS], after[FS_INV_MAX_LEGS];
    double cut[2 * FS_INV_MAX_LEGS + 2];
    int nc = 0;
    cut[nc++] = 0.0;
    cut[nc++] = Th;
    for (int k = 0; k < nl; ++k) {
        double d = duty[k];
        if (half == 0) { before[k] = 0; after[k] = 1; edge[k] = (1.0 - d) * Th; }
        else           { before[k] = 1; after[k] = 0; edge[k] = d * Th; }
        if (d <= 0.0 || d >= 1.0) {   /* no edge: the pole stays put */
            int s = d >= 1.0;
            before[k] = after[k] = s;
            edge[k] = Th;
            dead_end[k] = Th;
            continue;
        }
        dead_end[k] = fmin(edge[k] + c->t_dead, Th);
        cut[nc++] = edge[k];
        cut[nc++] = dead_end[k];
    }
    /* insertion sort of the cut instants */
    for (int a = 1; a < nc; ++a) {
        double v = cut[a];
        int b = a - 1;
        while (b >= 0 && cut[b] > v) { cut[b + 1] = cut[b]; --b; }
        cut[b + 1] = v;
    }
    seg->n = 0;
    for (int a = 0; a + 1 < nc; ++a) {
        double t0 = cut[a], t1 = cut[a + 1];
        if (t1 - t0 <= 1e-15) continue;
        double tm = 0.5 * (t0 + t1);
        int s = seg->n++;
        seg->dt[s] = t1 - t0;
        for (int k = 0; k < nl; ++k) {
            if (tm < edge[k]) seg->state[s][k] = before[k];
            else if (tm < dead_end[k]) seg->state[s][k] = -1;
            else seg->state[s][k] = after[k];
        }
    }
}

/* A leg's rail in switch state `state` at current i: in dead time (-1) its
 * diode's, the lower one for a current out of the leg (i >= 0), else the upper. */
static int rail_of(int state, double i) { return state < 0 ? i < 0.0 : state; }

int fs_inverter_same_voltage(const fs_inverter_config *c, const fs_inv_segments *seg, int n, const double *i_ph)
{
    if (c->dev.enabled || c->u_on != 0.0 || c->r_on != 0.0) return 1;
    const int nl = legs(c);
    int span = 1;
    for (; n + span < seg->n; ++span) {
        const int *next = seg->state[n + span];
        for (int k = 0; k < nl; ++k)
            if (next[k] < 0 || next[k] != rail_of(seg->state[n][k], i_ph[k])) return span;
    }
    return span;
}

void fs_inverter_legs(const fs_inverter_config *c, const int *state, const double *i_ph, double *s, double *drop)
{
    const int nl = legs(c);
    for (int k = 0; k < nl; ++k) {
        const double i = i_ph[k];
        if (state[k] < 0) {   /* dead time: a diode, on the rail opposite to the current's sign */
            s[k] = rail_of(state[k], i);
            drop[k] = c->dev.enabled ? fs_device_drop(&c->dev, 0, i) : sgn(i) * c->u_on + c->r_on * i;
        } else {
            s[k] = state[k];
            drop[k] = c->dev.enabled ? fs_device_drop(&c->dev, fs_device_transistor(&c->dev, state[k], i), i)
                                     : sgn(i) * c->u_on + c->r_on * i;
        }
    }
}

/* The dead time's volt-seconds per period of a leg at duty d (clipped to
 * [0, 1]) carrying i, as the switching model cuts them, s. */
static double dead_error(const fs_inverter_config *c, double d, double i)
{
    const double Th = 0.5 * c->T_pwm;
    if (d > 0.0 && d < 1.0) {
        if (i > 0.0) return -fmin(c->t_dead, d * Th);
        if (i < 0.0) return fmin(c->t_dead, (1.0 - d) * Th);
    }
    return 0.0;
}

static double clip01(double d) { return d < 0.0 ? 0.0 : (d > 1.0 ? 1.0 : d); }

void fs_inverter_mean_legs(const fs_inverter_config *c, const double *duty, const double *i_ph, double *s,
                           double *drop)
{
    const int nl = legs(c);
    for (int k = 0; k < nl; ++k) {
        const double d = clip01(duty[k]), i = i_ph[k];
        s[k] = d + dead_error(c, d, i) / c->T_pwm;
        if (c->dev.enabled) {   /* each rail's conducting device for its share of the period */
            const double up = fs_device_drop(&c->dev, fs_device_transistor(&c->dev, 1, i), i);
            const double lo = fs_device_drop(&c->dev, fs_device_transistor(&c->dev, 0, i), i);
            drop[k] = s[k] * up + (1.0 - s[k]) * lo;
        } else {
            drop[k] = sgn(i) * c->u_on + c->r_on * i;
        }
    }
}

double fs_inverter_commutations(const fs_inverter_config *c, const int *before, const int *after, const double *i_ph)
{
    if (!c->dev.enabled) return 0.0;
    double E = 0.0;
    for (int k = 0; k < legs(c); ++k)
        if (before[k] >= 0 && after[k] != before[k]) E += fs_device_commutation(&c->dev, before[k], i_ph[k], c->u_dc);
    return E;
}

/* Pole voltages (against the dc-link midpoint) of a switch state. */
static void pole_voltages(const fs_inverter_config *c, int nl, const int *state, const double *i_ph,
                          double *v)
{
    if (c->dev.enabled) {
        double s[FS_INV_MAX_LEGS], drop[FS_INV_MAX_LEGS];
        fs_inverter_legs(c, state, i_ph, s, drop);
        for (int k = 0; k < nl; ++k) v[k] = (s[k] - 0.5) * c->u_dc - drop[k];
        return;
    }
    for (int k = 0; k < nl; ++k) {
        const int s = rail_of(state[k], i_ph[k]);
        v[k] = (s ? 0.5 : -0.5) * c->u_dc - sgn(i_ph[k]) * c->u_on - c->r_on * i_ph[k];
    }
}

/* Mean pole voltages over a period (averaged model). */
static void mean_pole_voltages(const fs_inverter_config *c, int nl, const double *duty,
                               const double *i_ph, double *v)
{
    if (c->dev.enabled) {
        double s[FS_INV_MAX_LEGS], drop[FS_INV_MAX_LEGS];
        fs_inverter_mean_legs(c, duty, i_ph, s, drop);
        for (int k = 0; k < nl; ++k) v[k] = (s[k] - 0.5) * c->u_dc - drop[k];
        return;
    }
    for (int k = 0; k < nl; ++k) {
        const double d = clip01(duty[k]), err = dead_error(c, d, i_ph[k]);
        v[k] = (d - 0.5 + err / c->T_pwm) * c->u_dc - sgn(i_ph[k]) * c->u_on - c->r_on * i_ph[k];
    }
}

void fs_inverter_phase_voltages(const fs_inverter_config *c, const int *state, const double *i_ph,
                                double *u_ph)
{
    const int nl = legs(c);
    pole_voltages(c, nl, state, i_ph, u_ph);
    double mean = 0.0;
    for (int k = 0; k < nl; ++k) mean += u_ph[k];
    mean /= nl;
    for (int k = 0; k < nl; ++k) u_ph[k] -= mean;
}

/* Stationary voltages of pole voltages: Clarke or the VSD, both of which
 * drop the zero sequence, so the star point needs no subtraction here. */
static void stationary(const fs_inverter_config *c, const double *v, double *u_alpha, double *u_beta,
                       double *u_x, double *u_y)
{
    if (c->phases == 5) {
        fs_inverter_vsd5(v, u_alpha, u_beta, u_x, u_y);
    } else {
        clarke(v, u_alpha, u_beta);
        *u_x = *u_y = 0.0;
    }
}

void fs_inverter_voltage(const fs_inverter_config *c, const int *state, const double *i_ph,
                         double *u_alpha, double *u_beta, double *u_x, double *u_y)
{
    double v[FS_INV_MAX_LEGS];
    pole_voltages(c, legs(c), state, i_ph, v);
    stationary(c, v, u_alpha, u_beta, u_x, u_y);
}

void fs_inverter_mean_voltage(const fs_inverter_config *c, const double *duty, const double *i_ph,
                              double *u_alpha, double *u_beta, double *u_x, double *u_y)
{
    double v[FS_INV_MAX_LEGS];
    mean_pole_voltages(c, legs(c), duty, i_ph, v);
    stationary(c, v, u_alpha, u_beta, u_x, u_y);
}

void fs_inverter_mean_voltage_ideal(const fs_inverter_config *c, const double *duty, double *u_alpha,
                                    double *u_beta, double *u_x, double *u_y)
{
    double v[FS_INV_MAX_LEGS];
    const int nl = legs(c);
    for (int k = 0; k < nl; ++k) v[k] = (clip01(duty[k]) - 0.5) * c->u_dc;   /* mean_pole_voltages at i = 0 */
    stationary(c, v, u_alpha, u_beta, u_x, u_y);
}
