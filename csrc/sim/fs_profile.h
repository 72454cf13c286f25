/* Piecewise-linear profiles, owned copies (simulation side). */
#ifndef FS_PROFILE_H
#define FS_PROFILE_H

#include "fs_sim.h"

typedef struct {
    int n;
    double *t, *y;
    int k;           /* cached segment index: time moves forward */
    /* The last evaluation's piece, kept for the next: for lo < t < hi the
     * value is y0 + sl (t - t0) (lin) or y0, the slope sl. The open interval
     * leaves a breakpoint itself to fs_pwl_eval_at, whose formula there can
     * differ (y[0] at t[0] exactly); NaN bounds (none yet) match no t. */
    double lo, hi, t0, y0, sl;
    int lin;
} fs_pwl;

int fs_pwl_copy(fs_pwl *p, const fs_profile *src);
void fs_pwl_free(fs_pwl *p);
/* Value at t and slope there (0 outside the breakpoints), found from the
 * breakpoints; it keeps the piece it used in p. */
double fs_pwl_eval_at(fs_pwl *p, double t, double *slope);

/* The same, from the kept piece where t is inside it (a profile is read a
 * few times a sample, at the same or a later time: the same bits, without
 * the search). */
static inline double fs_pwl_eval(fs_pwl *p, double t, double *slope)
{
    if (t > p->lo && t < p->hi) {
        if (slope) *slope = p->sl;
        return p->lin ? p->y0 + p->sl * (t - p->t0) : p->y0;
    }
    return fs_pwl_eval_at(p, t, slope);
}

#endif /* FS_PROFILE_H */
