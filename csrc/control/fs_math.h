/* Inline helpers shared by the control modules (not part of the cdef). */
#ifndef FS_MATH_H
#define FS_MATH_H

#include <math.h>
#include <stdbool.h>

#define FS_PI 3.14159265358979323846f
#define FS_TWO_PI 6.28318530717958647692f
#define FS_SQRT3 1.73205080756887729353f
#define FS_INV_SQRT3 0.57735026918962576451f

/* Wrap an angle to (-pi, pi]. Valid for any finite input: fmodf is exact,
 * and one correction on either side lands in the interval. */
static inline float fs_wrap_pi(float x)
{
    if (x > FS_PI || x <= -FS_PI) {
        x = fmodf(x, FS_TWO_PI);
        if (x > FS_PI) {
            x -= FS_TWO_PI;
        } else if (x <= -FS_PI) {
            x += FS_TWO_PI;
        }
    }
    return x;
}

/* Configuration checks for the inits: each fails on NaN and on an infinity
 * (a double beyond the float range arrives as one). */
static inline bool fs_fin(float x) { return fabsf(x) < INFINITY; }
static inline bool fs_pos(float x) { return x > 0.0f && x < INFINITY; }
static inline bool fs_nonneg(float x) { return x >= 0.0f && x < INFINITY; }

static inline float fs_clampf(float x, float lo, float hi)
{
    return x < lo ? lo : (x > hi ? hi : x);
}

static inline float fs_signf(float x)
{
    return (x > 0.0f) ? 1.0f : ((x < 0.0f) ? -1.0f : 0.0f);
}

#endif /* FS_MATH_H */
