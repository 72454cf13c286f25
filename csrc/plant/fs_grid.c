#include "fs_grid.h"

#include <complex.h>
#include <math.h>

static double w_grid(const fs_grid_config *c) { return 2.0 * 3.14159265358979323846 * c->f_grid; }

fs_status fs_grid_check(const fs_grid_config *c)
{
    if (!c) return FS_ERR_NULL;
    const double v[5] = {c->V_im, c->f_grid, c->L_f, c->R_f, c->C_f};
    for (int k = 0; k < 5; ++k) {
        if (!(v[k] > 0.0) || !isfinite(v[k])) return FS_ERR_PARAM;
    }
    return FS_OK;
}

void fs_grid_voltage(const fs_grid_config *c, double t, double *e_a, double *e_b)
{
    const double th = w_grid(c) * t;
    *e_a = c->V_im * cos(th);
    *e_b = c->V_im * sin(th);
}

void fs_grid_initial_state(const fs_grid_config *c, double *x)
{
    /* phasors of e^{j w t}: E = V_im, V_c = E Z_c / (Z_f + Z_c) */
    const double w = w_grid(c);
    const double complex z_l = I * w * c->L_f;
    const double complex z_f = z_l * c->R_f / (z_l + c->R_f);
    const double complex z_c = 1.0 / (I * w * c->C_f);
    const double complex v_c = c->V_im * z_c / (z_f + z_c);
    const double complex i_l = (c->V_im - v_c) / z_l;
    for (int k = 0; k < FS_GRID_X_N; ++k) x[k] = 0.0;
    x[FS_GRID_X_IL_A] = creal(i_l);
    x[FS_GRID_X_IL_B] = cimag(i_l);
    x[FS_GRID_X_VC_A] = creal(v_c);
    x[FS_GRID_X_VC_B] = cimag(v_c);
}

void fs_grid_deriv(const fs_grid_config *c, double t, const double *x, double i_in_a, double i_in_b,
                   double *dx, double *i_g_a)
{
    double e_a, e_b;
    fs_grid_voltage(c, t, &e_a, &e_b);
    const double u_a = e_a - x[FS_GRID_X_VC_A], u_b = e_b - x[FS_GRID_X_VC_B];
    const double ig_a = x[FS_GRID_X_IL_A] + u_a / c->R_f, ig_b = x[FS_GRID_X_IL_B] + u_b / c->R_f;
    dx[FS_GRID_X_IL_A] = u_a / c->L_f;
    dx[FS_GRID_X_IL_B] = u_b / c->L_f;
    dx[FS_GRID_X_VC_A] = (ig_a - i_in_a) / c->C_f;
    dx[FS_GRID_X_VC_B] = (ig_b - i_in_b) / c->C_f;
    dx[FS_GRID_X_E_GRID] = 1.5 * (e_a * ig_a + e_b * ig_b);
    dx[FS_GRID_X_E_RF] = 1.5 * (u_a * u_a + u_b * u_b) / c->R_f;
    if (i_g_a) *i_g_a = ig_a;
}

double fs_grid_energy(const fs_grid_config *c, const double *x)
{
    const double il2 = x[FS_GRID_X_IL_A] * x[FS_GRID_X_IL_A] + x[FS_GRID_X_IL_B] * x[FS_GRID_X_IL_B];
    const double vc2 = x[FS_GRID_X_VC_A] * x[FS_GRID_X_VC_A] + x[FS_GRID_X_VC_B] * x[FS_GRID_X_VC_B];
    return 0.75 * (c->L_f * il2 + c->C_f * vc2);
}
