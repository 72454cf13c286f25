/* Maximum torque per ampere for a linear-magnetic PMSM (Ld <= Lq).
 *
 * On the MTPA locus the d-current for a current magnitude I is
 *   i_d = (psi_f - sqrt(psi_f^2 + 8 (L_q - L_d)^2 I^2)) / (4 (L_q - L_d)),
 * and i_d = 0 for a non-salient machine. init tabulates torque against I up
 * to i_max; step inverts the table for a torque reference. The locus does
 * not depend on the number of phases; the torque scales with it.
 */
#ifndef FS_MTPA_H
#define FS_MTPA_H

#include "fs_transforms.h"
#include "fs_types.h"

enum { FS_MTPA_N = 64 };

typedef struct {
    float L_d, L_q;   /* H */
    float psi_f;      /* Wb */
    int pole_pairs;
    float i_max;      /* A, peak */
    int phases;       /* 3 or 5: T = (phases / 2) p (psi_f + (L_d - L_q) i_d) i_q */
} fs_mtpa_config;

typedef struct {
    fs_mtpa_config cfg;
    float T[FS_MTPA_N];    /* torque at each table point, N m, rising */
    float i_d[FS_MTPA_N];  /* A */
    float i_q[FS_MTPA_N];  /* A */
} fs_mtpa;

fs_status fs_mtpa_init(fs_mtpa *m, const fs_mtpa_config *cfg);
/* The MTPA current for torque T_ref (either sign), limited to i_max. */
fs_dq fs_mtpa_step(const fs_mtpa *m, float T_ref);

#endif /* FS_MTPA_H */
