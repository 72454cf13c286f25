/* The input side of an indirect matrix converter (double), for simulation:
 * a stiff three-phase grid and the LC input filter (zou2021 sec. 5.1).
 *
 * Grid, eq. (1): e = V_im (cos w t, cos(w t - 2 pi/3), cos(w t + 2 pi/3)).
 * Filter, per phase: an inductor L_f with its damping resistor R_f in
 * parallel, from the grid to a star of capacitors C_f at the converter's
 * input. Both star points float, so the stationary (alpha, beta) frame
 * (amplitude-invariant) holds everything:
 *   L_f di_L/dt = e - v_c,
 *   C_f dv_c/dt = i_L + (e - v_c)/R_f - i_in,
 *   i_g = i_L + (e - v_c)/R_f          (the grid current),
 * with i_in the rectifier's input current. Meters: E_GRID = 3/2 int e.i_g
 * (energy from the grid), E_RF = 3/2 int |e - v_c|^2/R_f (damping loss), so
 * E_GRID = E_RF + stored (fs_grid_energy) + 3/2 int v_c.i_in.
 */
#ifndef FS_GRID_H
#define FS_GRID_H

#include "../control/fs_types.h"

typedef struct {
    double V_im;      /* phase voltage amplitude, V */
    double f_grid;    /* Hz */
    double L_f;       /* H */
    double R_f;       /* ohm, in parallel with L_f */
    double C_f;       /* F, star-connected */
} fs_grid_config;

enum {
    FS_GRID_X_IL_A = 0, FS_GRID_X_IL_B,   /* inductor current, stationary frame */
    FS_GRID_X_VC_A, FS_GRID_X_VC_B,       /* capacitor voltage, stationary frame */
    FS_GRID_X_E_GRID, FS_GRID_X_E_RF,     /* energy meters, J */
    FS_GRID_X_N
};

/* FS_OK (0), or FS_ERR_PARAM if a field is not a positive finite number. */
fs_status fs_grid_check(const fs_grid_config *c);
/* The sinusoidal steady state without load at t = 0, meters zero. */
void fs_grid_initial_state(const fs_grid_config *c, double *x);
/* Grid voltage at t, stationary frame. */
void fs_grid_voltage(const fs_grid_config *c, double t, double *e_a, double *e_b);
/* Right-hand side at t for the rectifier's input current (i_a, i_b); if
 * i_g_a is not NULL it receives the grid current of phase a. */
void fs_grid_deriv(const fs_grid_config *c, double t, const double *x, double i_in_a, double i_in_b,
                   double *dx, double *i_g_a);
/* Energy stored in the filter, 3/2 (L_f |i_L|^2 + C_f |v_c|^2)/2, J. */
double fs_grid_energy(const fs_grid_config *c, const double *x);

#endif /* FS_GRID_H */
