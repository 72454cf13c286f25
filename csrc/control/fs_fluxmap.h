/* The machine's flux map in the controller: psi_d(i_d, i_q), psi_q(i_d, i_q).
 *
 * A saturating machine's inductances move with its current (a traction
 * IPMSM's L_q halves between no load and its current limit): a model of
 * constant L_d, L_q puts the back-EMF observer's angle off by the ratio of
 * the q flux it mis-predicts to the active flux (the 2004 Prius MG2 with its
 * rated-current inductances: 25 el.deg at 80 A), and leaves flux weakening
 * without the voltage its ellipse really has. The drive takes the map as a
 * table in its configuration (fullspeed.design.magnetics resamples the
 * machine's map onto this grid) and evaluates it where it needs a flux or an
 * inductance.
 *
 * The grid: FS_FLUXMAP_ND currents i_d0 + k di_d and FS_FLUXMAP_NQ currents
 * l di_q >= 0; below i_q = 0 the map is the machine's mirror image,
 * psi_d(i_d, -i_q) = psi_d(i_d, i_q), psi_q(i_d, -i_q) = -psi_q(i_d, i_q).
 * The fluxes are held as 16-bit counts of psi_scale (a 1.5 kB table is
 * 0.9 kB; the rounding, 1.5e-5 of the largest flux, is far below what a map
 * knows). Between the points the map is bilinear; beyond the grid it goes
 * on with its edge cells' slopes (a linear extension, not a clamp: a
 * saturated machine's flux keeps rising at its incremental inductance).
 * 13 x 17 points: over a grid from -i_max to i_max / 2 and 0 to i_max the q
 * step is i_max / 16, where bilinear interpolation misses the Prius MG2's
 * q flux (L_q(i) = L_0 / (1 + |i| / 238 A)) by at most 0.1 % (0.1 el.deg of
 * the observer's angle), and the d step i_max / 8 (the d flux bends less).
 */
#ifndef FS_FLUXMAP_H
#define FS_FLUXMAP_H

#include "fs_transforms.h"
#include "fs_types.h"

/* FS_WITH_FLUXMAP 0 (fs_drive.h, compile-time options): the controller
 * without a flux map; its code is not linked and a map is refused. */
#ifndef FS_WITH_FLUXMAP
#define FS_WITH_FLUXMAP 1
#endif

enum { FS_FLUXMAP_ND = 13, FS_FLUXMAP_NQ = 17, FS_FLUXMAP_N = 221 };   /* N = ND NQ */

/* In the drive's configuration: no pointer, the same bytes on every target. */
typedef struct {
    float di_d;          /* A, the d step (0: no map) */
    float i_d0;          /* A, the first d current */
    float di_q;          /* A, the q step (the grid starts at i_q = 0) */
    float psi_scale;     /* Wb per count */
    int16_t psi_d[FS_FLUXMAP_N];   /* counts at (i_d0 + k di_d, l di_q), index k NQ + l */
    int16_t psi_q[FS_FLUXMAP_N];
} fs_fluxmap_table;

/* The map at one current: the fluxes and the incremental inductances
 * d psi_d / d i_d, d psi_q / d i_q of the cell (the slopes a current
 * regulator and a carrier see), and the cross terms d psi_d / d i_q,
 * d psi_q / d i_d (cross-saturation). */
typedef struct {
    fs_dq psi;           /* Wb */
    float L_dd, L_qq;    /* H */
    float L_dq, L_qd;    /* H */
} fs_fluxmap_point;

typedef struct {
    const fs_fluxmap_table *t;   /* not copied: the caller keeps it (the drive's own config) */
    float inv_di_d, inv_di_q;
} fs_fluxmap;

/* Refuses a grid that is not finite and rising (steps > 0, scale > 0) and a
 * map whose fluxes do not rise with their own current (psi_d with i_d,
 * psi_q with i_q): an incremental inductance <= 0 is no machine. */
fs_status fs_fluxmap_init(fs_fluxmap *m, const fs_fluxmap_table *t);
fs_fluxmap_point fs_fluxmap_eval(const fs_fluxmap *m, fs_dq i);
/* The incremental inductances d psi_d / d i_d and d psi_q / d i_q continuous
 * across the grid's lines: each cell's slope (the bilinear map's, constant
 * along its own axis) stands at the cell's centre, and between two centres
 * the slope is interpolated linearly (the derivative of the map smoothed
 * over a cell; at the grid's edges the edge cell's slope, as the map goes
 * on). The bilinear map's own slope steps at each line (SyR-e's THOR's L_qq
 * from 16.4 to 12.2 mH at i_q = 11 A); a current regulator whose gains
 * follow the incremental inductance (fs_current_ctrl.h) must not see that
 * step where the current sits on a line. */
void fs_fluxmap_slopes(const fs_fluxmap *m, fs_dq i, float *L_dd, float *L_qq);
/* The q flux's secant inductance psi_q / i_q at p (the incremental one where
 * i_q is within a tenth of a step of 0: the limit of the secant there). */
float fs_fluxmap_secant_q(const fs_fluxmap *m, fs_dq i, const fs_fluxmap_point *p);

#endif /* FS_FLUXMAP_H */
