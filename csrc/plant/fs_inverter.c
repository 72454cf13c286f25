#include "fs_inverter.h"

#include <math.h>

static double sgn(double x) { return (x > 0.0) - (x < 0.0); }

static void clarke(const double v[3], double *a, double *b)
{
    *a = (2.0 * v[0] - v[1] - v[2]) / 3.0;
    *b = (v[1] - v[2]) / sqrt(3.0);
}

void fs_inverter_segments(const fs_inverter_config *c, const double duty[3], int half,
                          fs_inv_segments *seg)
{
    const double Th = 0.5 * c->T_pwm;
    double edge[3], dead_end[3];
    int before[3], after[3];
    double cut[2 * 3 + 2];
    int nc = 0;
    cut[nc++] = 0.0;
    cut[nc++] = Th;
    for (int k = 0; k < 3; ++k) {
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
        for (int k = 0; k < 3; ++k) {
            if (tm < edge[k]) seg->state[s][k] = before[k];
            else if (tm < dead_end[k]) seg->state[s][k] = -1;
            else seg->state[s][k] = after[k];
        }
    }
}

void fs_inverter_voltage(const fs_inverter_config *c, const int state[3], const double i_abc[3],
                         double *u_alpha, double *u_beta)
{
    double v[3];
    for (int k = 0; k < 3; ++k) {
        int s = state[k];
        if (s < 0) s = i_abc[k] < 0.0;  /* diode: i > 0 flows through the lower one */
        v[k] = (s ? 0.5 : -0.5) * c->u_dc - sgn(i_abc[k]) * c->u_on;
    }
    clarke(v, u_alpha, u_beta);
}

void fs_inverter_mean_voltage(const fs_inverter_config *c, const double duty[3],
                              const double i_abc[3], double *u_alpha, double *u_beta)
{
    double v[3];
    const double Th = 0.5 * c->T_pwm;
    for (int k = 0; k < 3; ++k) {
        double d = duty[k] < 0.0 ? 0.0 : (duty[k] > 1.0 ? 1.0 : duty[k]);
        double err = 0.0;  /* dead-time volt-seconds per period, as the switching model cuts them */
        if (d > 0.0 && d < 1.0) {
            if (i_abc[k] > 0.0) err = -fmin(c->t_dead, d * Th);
            else if (i_abc[k] < 0.0) err = fmin(c->t_dead, (1.0 - d) * Th);
        }
        v[k] = (d - 0.5 + err / c->T_pwm) * c->u_dc - sgn(i_abc[k]) * c->u_on;
    }
    clarke(v, u_alpha, u_beta);
}
