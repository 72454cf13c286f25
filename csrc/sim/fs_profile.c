#include "fs_profile.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int fs_pwl_copy(fs_pwl *p, const fs_profile *src)
{
    memset(p, 0, sizeof(*p));
    p->lo = p->hi = NAN;
    if (src->n <= 0) return 0;  /* empty: zero */
    if (!src->t || !src->y) return -1;
    for (int k = 1; k < src->n; ++k) {
        if (!(src->t[k] >= src->t[k - 1])) return -1;
    }
    p->t = malloc(sizeof(double) * (size_t)src->n);
    p->y = malloc(sizeof(double) * (size_t)src->n);
    if (!p->t || !p->y) { fs_pwl_free(p); return -1; }
    memcpy(p->t, src->t, sizeof(double) * (size_t)src->n);
    memcpy(p->y, src->y, sizeof(double) * (size_t)src->n);
    p->n = src->n;
    return 0;
}

void fs_pwl_free(fs_pwl *p)
{
    free(p->t);
    free(p->y);
    p->t = p->y = NULL;
    p->n = 0;
}

/* Keep the piece (lo, hi) for fs_pwl_eval: value y0, or y0 + sl (t - t0) if lin. */
static void keep(fs_pwl *p, double lo, double hi, double t0, double y0, double sl, int lin)
{
    p->lo = lo;
    p->hi = hi;
    p->t0 = t0;
    p->y0 = y0;
    p->sl = sl;
    p->lin = lin;
}

double fs_pwl_eval_at(fs_pwl *p, double t, double *slope)
{
    if (slope) *slope = 0.0;
    if (p->n == 0) {
        keep(p, -INFINITY, INFINITY, 0.0, 0.0, 0.0, 0);
        return 0.0;
    }
    if (t <= p->t[0]) {
        keep(p, -INFINITY, p->t[0], 0.0, p->y[0], 0.0, 0);
        return p->y[0];
    }
    if (t >= p->t[p->n - 1]) {
        keep(p, p->t[p->n - 1], INFINITY, 0.0, p->y[p->n - 1], 0.0, 0);
        return p->y[p->n - 1];
    }
    if (p->k >= p->n - 1 || p->t[p->k] > t) p->k = 0;
    while (p->k < p->n - 2 && p->t[p->k + 1] <= t) ++p->k;
    double t0 = p->t[p->k], t1 = p->t[p->k + 1];
    double y0 = p->y[p->k], y1 = p->y[p->k + 1];
    if (t1 <= t0) return y1;  /* a step */
    double s = (y1 - y0) / (t1 - t0);
    if (slope) *slope = s;
    keep(p, t0, t1, t0, y0, s, 1);
    return y0 + s * (t - t0);
}
