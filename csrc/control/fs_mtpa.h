/* Maximum torque per ampere for a linear-magnetic PMSM (Ld <= Lq).
 *
 * On the MTPA locus the d-current for a current magnitude I is
 *   i_d = (psi_f - sqrt(psi_f^2 + 8 (L_q - L_d)^2 I^2)) / (4 (L_q - L_d)),
 * and i_d = 0 for a non-salient machine. init tabulates torque against I up
 * to i_max; step inverts the table for a torque reference. The locus does
 * not depend on the number of phases; the torque scales with it.
 *
 * A machine known by its flux map (saturation, cross-saturation:
 * fs_fluxmap.h) has its locus searched on the map at init: at each current
 * magnitude |i| = i_max k / (N - 1), k = 0..N-1, the current angle of most
 * torque (phases / 2) p (psi_d i_q - psi_q i_d), by golden-section search
 * over 0..pi (the torque along a circle has one maximum
 * there); step then interpolates the table linearly.
 */
#ifndef FS_MTPA_H
#define FS_MTPA_H

#include "fs_fluxmap.h"
#include "fs_transforms.h"
#include "fs_types.h"

enum { FS_MTPA_N = 64 };

typedef struct {
    float L_d, L_q;   /* H */
    float psi_f;      /* Wb */
    int pole_pairs;
    float i_max;      /* A, peak */
    int phases;       /* 3 or 5: T = (phases / 2) p (psi_f + (L_d - L_q) i_d) i_q */
    const fs_fluxmap *map;   /* NULL: the locus of L_d, L_q, psi_f; else searched on the map at init (not kept) */
} fs_mtpa_config;

typedef struct {
    fs_mtpa_config cfg;
    float T[FS_MTPA_N];    /* torque at each table point, N m, rising */
    float i_d[FS_MTPA_N];  /* A */
    float i_q[FS_MTPA_N];  /* A */
    int tabulated;         /* 1: the locus was searched on a map (step interpolates it) */
    float k_T;             /* (phases / 2) p: torque per (flux x current) */
    int seg;               /* the table segment of the last step (where step looks first) */
    /* the linear locus' constants, formed once as the step formed them: L_q - L_d,
     * 2 (L_q - L_d), 4 (L_q - L_d)^2, psi_f^2; salient: L_q - L_d > 1e-9 L_q */
    float dL, dL2, dL4, psi2;
    int salient;
} fs_mtpa;

fs_status fs_mtpa_init(fs_mtpa *m, const fs_mtpa_config *cfg);
/* The MTPA current for torque T_ref (either sign), limited to i_max. */
fs_dq fs_mtpa_step(fs_mtpa *m, float T_ref);

#endif /* FS_MTPA_H */
