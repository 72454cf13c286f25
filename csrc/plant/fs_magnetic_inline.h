/* The magnetic model's linear current solve inline, for the plant's
 * right-hand side (which asks four times a step): not part of the cdef
 * (_build.py reads fs_magnetic.h, where cffi takes no function bodies). */
#ifndef FS_MAGNETIC_INLINE_H
#define FS_MAGNETIC_INLINE_H

#include "fs_magnetic.h"

/* LINEAR's currents, which fs_mag_current gives for that kind. */
static inline void fs_mag_current_linear(const fs_mag *m, double psi_d, double psi_q, double *i_d, double *i_q)
{
    *i_d = (psi_d - m->cfg.psi_f) / m->cfg.L_d;
    *i_q = psi_q / m->cfg.L_q;
}
/* fs_mag_current, with LINEAR's two divisions inline at the caller (the
 * plant's right-hand side asks four times a step): the same bits. */
static inline void fs_mag_current_at(fs_mag *m, double psi_d, double psi_q, double *i_d, double *i_q)
{
    if (m->cfg.kind == FS_MAG_LINEAR) {
        fs_mag_current_linear(m, psi_d, psi_q, i_d, i_q);
    } else {
        fs_mag_current(m, psi_d, psi_q, i_d, i_q);
    }
}

#endif /* FS_MAGNETIC_INLINE_H */
