/* Piecewise-linear profiles, owned copies (simulation side). */
#ifndef FS_PROFILE_H
#define FS_PROFILE_H

#include "fs_sim.h"

typedef struct {
    int n;
    double *t, *y;
    int k;           /* cached segment index: time moves forward */
} fs_pwl;

int fs_pwl_copy(fs_pwl *p, const fs_profile *src);
void fs_pwl_free(fs_pwl *p);
/* Value at t and slope there (0 outside the breakpoints). */
double fs_pwl_eval(fs_pwl *p, double t, double *slope);

#endif /* FS_PROFILE_H */
