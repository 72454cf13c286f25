/* Five-phase vector space decomposition (VSD), amplitude-invariant (yu2022).
 *
 * Phase k = 0..4 (A..E) lies at k g, g = 2 pi / 5. The five phase values map
 * onto two orthogonal planes and a zero sequence:
 *   alpha = 2/5 sum_k x_k cos(k g),    beta = 2/5 sum_k x_k sin(k g)
 *       fundamental plane: torque and flux (d-q after a Park by theta_e)
 *   x     = 2/5 sum_k x_k cos(3 k g),  y    = 2/5 sum_k x_k sin(3 k g)
 *       third-harmonic plane: only losses in a sinusoidal machine
 *       (d3-q3 after a Park by 3 theta_e)
 *   zero  = 1/5 sum_k x_k
 * Inverse: x_k = alpha cos(kg) + beta sin(kg) + x cos(3kg) + y sin(3kg) + zero.
 * A balanced set A cos(theta - k g) gives ab = A (cos theta, sin theta), xy = 0;
 * a third-harmonic set A cos(3 (theta - k g)) gives xy = A (cos 3theta, sin 3theta).
 */
#ifndef FS_VSD_H
#define FS_VSD_H

#include "fs_transforms.h"

typedef struct {
    fs_ab ab;    /* fundamental plane (alpha, beta) */
    fs_ab xy;    /* third-harmonic plane (x, y) in the alpha, beta fields */
    float zero;  /* zero sequence: the mean of the phases */
} fs_vsd5;

/* Phase values (A..E) -> planes. */
fs_vsd5 fs_vsd5_forward(const float x[5]);
/* Planes -> phase values (A..E). */
void fs_vsd5_inverse(const fs_vsd5 *v, float x[5]);

#endif /* FS_VSD_H */
