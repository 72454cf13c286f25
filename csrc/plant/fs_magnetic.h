/* Magnetic models of a three-phase PMSM in rotor coordinates (double).
 *
 * The stator flux linkages are the states; a model gives the currents from
 * the fluxes, i = i(psi), and the magnetic energy W(psi) with i = grad W, so
 * that power is conserved exactly by construction.
 *
 * LINEAR     psi_d = L_d i_d + psi_f, psi_q = L_q i_q.
 * ALGEBRAIC  self- and cross-saturation by the algebraic model of Hinkkanen,
 *            Pescetto, Molsa, Saarakkala, Pellegrino and Bojoi, "Sensorless
 *            self-commissioning of synchronous reluctance motors at standstill
 *            without rotor locking", IEEE Trans. Ind. Appl. 53(3), 2017, with
 *            the magnet as an equivalent d-axis current i_f (as for PM-assisted
 *            machines):
 *              i_d + i_f = (a_d0 + a_dd |psi_d|^S + a_dq/(V+2) |psi_d|^U |psi_q|^(V+2)) psi_d
 *              i_q       = (a_q0 + a_qq |psi_q|^T + a_dq/(U+2) |psi_d|^(U+2) |psi_q|^V) psi_q
 *            i_f is set so that psi_d = psi_f at zero current. Because the
 *            nonlinearity acts on the total d flux, a positive i_d saturates
 *            more than a negative one (the asymmetry that polarity detection
 *            uses), and i_q lowers psi_d at i_d = 0 (cross-saturation).
 * FLUXMAP    psi_d(i_d, i_q), psi_q(i_d, i_q) tables on a regular current grid
 *            (e.g. from FEA), interpolated bilinearly and inverted by Newton.
 */
#ifndef FS_MAGNETIC_H
#define FS_MAGNETIC_H

#include "../control/fs_types.h"

typedef enum { FS_MAG_LINEAR = 0, FS_MAG_ALGEBRAIC = 1, FS_MAG_FLUXMAP = 2 } fs_mag_kind;

/* Largest integer exponent of ALGEBRAIC taken by repeated multiplication. */
#define FS_MAG_POW_NMAX 64

typedef struct {
    int kind;                 /* fs_mag_kind */
    double L_d, L_q, psi_f;   /* LINEAR, and the unsaturated values of ALGEBRAIC */
    /* ALGEBRAIC: a_d0 = 1/L_d and a_q0 = 1/L_q are taken from L_d, L_q */
    double a_dd, a_qq, a_dq;  /* 1/(H Wb^S), ... */
    double S, T, U, V;        /* exponents */
    /* FLUXMAP: row-major [n_d][n_q]; grid i_d0 + k di_d, i_q0 + l di_q */
    int map_n_d, map_n_q;
    double map_i_d0, map_di_d, map_i_q0, map_di_q;
    const double *map_psi_d, *map_psi_q;
} fs_mag_config;

typedef struct {
    fs_mag_config cfg;
    double i_f;               /* ALGEBRAIC: magnet equivalent current */
    /* ALGEBRAIC, set by fs_mag_init: a_d0 = 1/L_d, a_q0 = 1/L_q,
     * c_d = a_dq/(V+2), c_q = a_dq/(U+2), and each exponent as an integer
     * 0..FS_MAG_POW_NMAX evaluated by multiplication, or -1 (then pow()). */
    double a_d0, a_q0, c_d, c_q;
    int n_S, n_T, n_U, n_V;
    double hint_d, hint_q;    /* FLUXMAP: last solution, Newton's start */
    double psi_f0, i_f0;      /* the magnet as configured (fs_mag_set_magnet scales it) */
} fs_mag;

/* FS_OK (0), or the status of the first field out of range or not finite:
 * FS_ERR_MODE (kind), FS_ERR_LD, FS_ERR_LQ, FS_ERR_PSI_F (L_d, L_q > 0 and
 * psi_f >= 0 for LINEAR and ALGEBRAIC, finite for FLUXMAP), FS_ERR_PARAM
 * (ALGEBRAIC: a coefficient or an exponent < 0, or a magnet current i_f
 * beyond the double range; FLUXMAP: fewer than 2 x 2 points, a step <= 0,
 * a map value not finite), FS_ERR_NULL (a map pointer). */
fs_status fs_mag_init(fs_mag *m, const fs_mag_config *cfg);
void fs_mag_current(fs_mag *m, double psi_d, double psi_q, double *i_d, double *i_q);
/* Flux linkages at given currents (the inverse of fs_mag_current). */
void fs_mag_flux(fs_mag *m, double i_d, double i_q, double *psi_d, double *psi_q);
/* fs_mag_flux at n currents in turn (the design's tables: one call, not n). */
void fs_mag_flux_n(fs_mag *m, const double *i_d, const double *i_q, int n, double *psi_d, double *psi_q);
/* The magnet's remanence at k times the configured one (temperature,
 * fs_thermal.h): LINEAR psi_f, ALGEBRAIC its equivalent current i_f (a
 * magnet on its recoil line is a current sheet proportional to its
 * remanence, so the open-circuit flux falls a little less than k where the
 * iron saturates). FLUXMAP: not modelled, unchanged. */
void fs_mag_set_magnet(fs_mag *m, double k);
/* Magnetic energy W(psi) - i_f psi_d per unit of the dq frame (times 3/2 for
 * the three-phase machine); NaN for FLUXMAP. */
double fs_mag_energy(const fs_mag *m, double psi_d, double psi_q);

#endif /* FS_MAGNETIC_H */
