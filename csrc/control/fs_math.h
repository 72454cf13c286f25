/* Inline helpers shared by the control modules, and the declaration of the
 * trigonometry they share (not part of the cdef). */
#ifndef FS_MATH_H
#define FS_MATH_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#define FS_PI 3.14159265358979323846f
#define FS_TWO_PI 6.28318530717958647692f
#define FS_SQRT3 1.73205080756887729353f
#define FS_INV_SQRT3 0.57735026918962576451f

/* FS_COLD: run once, at start-up (every unit's init and its designs), or
 * rarely (the resets, the answer to a loss of lock, fs_drive_protect.c; the
 * back-EMF tracker's re-design and zero crossing, fs_smo.c): GCC optimizes
 * such a function for size and keeps it apart from the step's code. The
 * arithmetic is the same (no reassociation, no contraction, as at any
 * level without -ffast-math), so are the results: only the production
 * image's flash shrinks. Not on what runs every step in some stage (a
 * reset the step calls while a unit is off, fs_monitor_reset): a call to a
 * cold function also marks the path to it unlikely. Not noinline: the
 * inits inlined into fs_drive_init fold the firmware's constant
 * configuration (noinline: 5.9 kB more flash) */
#if defined(__GNUC__)
#define FS_CONST __attribute__((const))
#define FS_OUT_OF_LINE static __attribute__((noinline, unused))
#define FS_COLD __attribute__((cold))
#else
#define FS_CONST
#define FS_OUT_OF_LINE static inline
#define FS_COLD
#endif

/* fmodf(x, 2 pi) (2 pi as a float), bit for bit: the remainder is exact,
 * so any exact way to it gives libm's bits. 2 pi times the largest power
 * of two with m <= |x| < 2 m, then halved down to 2 pi, taken off where it
 * fits: each difference exact (Sterbenz: m <= a < 2 m), |x| < 2 pi at the
 * end, with x's sign (a zero too, as fmodf). An infinity or NaN gives
 * fmodf's own (x y) / (x y). Written out because newlib's fmodf and its
 * wrapper were 440 B of the production image's 32 KB (bench/firmware.py);
 * test_trig.c compares it with fmodf. */
static inline float fs_fmod_2pi(float x)
{
    float a = fabsf(x);
    float r;
    if (!(a < INFINITY)) {
        r = (x * FS_TWO_PI) / (x * FS_TWO_PI);
    } else {
        float m = FS_TWO_PI;
        int n = 0;   /* the doublings: at most 125 below the largest float */
        bool more = true;
        for (int k = 0; (k < 128) && more; ++k) {
            if (a >= (2.0f * m)) {
                m *= 2.0f;
                ++n;
            } else {
                more = false;
            }
        }
        for (int k = 0; k <= n; ++k) {   /* m = 2 pi 2^n down to 2 pi */
            if (a >= m) {
                a -= m;
            }
            m *= 0.5f;
        }
        r = copysignf(a, x);
    }
    return r;
}

/* fs_wrap_pi off (-pi, pi) (+-pi, NaN and infinities included), out of
 * line: one copy, not one at every call site. Within a turn of the
 * interval (|x| < 3 pi: an angle and a step, a sum of two wrapped angles)
 * x -+ 2 pi alone lands in it, exactly (Sterbenz: |x| <= 4 pi), with the
 * bits fmodf's path gives; beyond, fmodf's remainder (exact,
 * fs_fmod_2pi) and one correction on either side. */
FS_OUT_OF_LINE float fs_wrap_far(float x)
{
    if (x == FS_PI) { return x; }
    const float y = x > 0.0f ? x - FS_TWO_PI : x + FS_TWO_PI;
    if (y > -FS_PI && y <= FS_PI && y != 0.0f) { return y; }   /* 0 is +-2 pi, whose sign fmodf sets */
    x = fs_fmod_2pi(x);
    if (x > FS_PI) {
        x -= FS_TWO_PI;
    } else if (x <= -FS_PI) {
        x += FS_TWO_PI;
    } else {
        /* in (-pi, pi] already */
    }
    return x;
}

/* Wrap an angle to (-pi, pi]. Valid for any finite input. */
static inline float fs_wrap_pi(float x)
{
    return fabsf(x) < FS_PI ? x : fs_wrap_far(x);   /* one comparison on the common path */
}

/* (int)ceilf(x), without libm's ceilf (140 B of the production image):
 * the truncation, one up where it dropped a fraction of a positive x;
 * from 2^23 on a float is whole, and x itself converts as its ceiling
 * did (NaN and beyond the int range as before). */
static inline int fs_ceil_int(float x)
{
    const int n = (int)x;
    return fabsf(x) < 8388608.0f && (float)n < x ? n + 1 : n;
}

/* Configuration checks for the inits: each fails on NaN and on an infinity
 * (a double beyond the float range arrives as one). */
static inline bool fs_fin(float x) { return fabsf(x) < INFINITY; }
static inline bool fs_pos(float x) { return x > 0.0f && x < INFINITY; }
static inline bool fs_nonneg(float x) { return x >= 0.0f && x < INFINITY; }

/* e^{j theta} = cos theta + j sin theta, both from one argument reduction
 * (fs_transforms.c): within 1 ulp of the exact values for |theta| < 199
 * rad (beyond, those at fs_wrap_pi(theta)), and the same float32 on every
 * platform (not the platform's libm: csrc/control calls no sinf, cosf or
 * tanf, but fs_cosf, fs_sinf and fs_tanf). A complex float is laid out as
 * float[2] (C99 6.2.5): cos, then sin. It depends on theta alone: to GCC
 * and clang, fs_cosf(t) and fs_sinf(t) of one angle are one call (a
 * function returning a struct would be called twice). */
float _Complex fs_cis(float theta) FS_CONST;

/* A complex float's parts (laid out as float[2], C99 6.2.5: real first),
 * read through a union of the two (C99 6.5.2.3, footnote 82: a member
 * read other than the one last stored gives the stored bytes as its own
 * type), not through a cast of its address to float *, whose second float
 * static analysers read as past the end of an object (cppcheck's
 * objectIndex and uninitvar); and without <complex.h>'s crealf and
 * cimagf, which a freestanding build need not have. */
typedef union {
    float _Complex z;
    float part[2];   /* real, imaginary */
} fs_cplx_parts;

static inline float fs_cre(float _Complex e) { const fs_cplx_parts v = { .z = e }; return v.part[0]; }
static inline float fs_cim(float _Complex e) { const fs_cplx_parts v = { .z = e }; return v.part[1]; }

/* re + j im, both parts as given, bit for bit (re + im * I would compute
 * sums: -0 + 0 is +0, and an infinite part makes a NaN of the other).
 * GCC: its builtin, C11's CMPLXF without <complex.h>. The union's
 * initialiser is the same value, but GCC's link-time optimisation kept a
 * stack frame in the functions that return one (fs_cis, cis_far, the
 * back-EMF tracker's step: 140 B more of the image's flash at -O2,
 * bench/firmware.py); the builtin gives the very instructions that
 * writing the parts through a float * gave. Other compilers (clang before
 * 12 has no such builtin): the union. */
static inline float _Complex fs_cplx(float re, float im)
{
#if defined(__GNUC__) && !defined(__clang__)
    return __builtin_complex(re, im);
#else
    const fs_cplx_parts v = { .part = { re, im } };
    return v.z;
#endif
}

/* e^x for a discrete filter's pole (x in [-1, 0]) as 1 + expm1f(x): within
 * an ulp there, and the image links one exponential (expm1f, which the
 * complements 1 - e^-x need exact when small) instead of two: newlib's
 * expf and its helpers took 0.5 kB of the target's flash */
static inline float fs_exp_pole(float x) { return 1.0f + expm1f(x); }

static inline float fs_cosf(float x) { return fs_cre(fs_cis(x)); }
static inline float fs_sinf(float x) { return fs_cim(fs_cis(x)); }

/* fs_cis's polynomials' tails (fs_transforms.c says how they were fitted):
 * cos r = 1 - r^2/2 + r^4 qc(r^2), sin r = r + r^3 qs(r^2) */
static inline float fs_cis_qc(float z) { return 0.041666646f + z * (-0.0013887316f + z * 2.4433157e-05f); }
static inline float fs_cis_qs(float z) { return -0.16666655f + z * (0.00833216f + z * -0.00019515282f); }

/* fs_cis's polynomials on its reduced argument r (|r| <= pi/4) and the
 * tail r_lo that reduction lost (fs_transforms.c says how they were fitted):
 * cos r + j sin r. */
static inline float _Complex fs_cis_poly(float r, float r_lo)
{
    const float z = r * r, hz = 0.5f * z, w = 1.0f - hz;
    const float c = w + (((1.0f - w) - hz) + (z * z * fs_cis_qc(z) - r * r_lo));
    const float s = r + (r * z * fs_cis_qs(z) + r_lo * w);
    return fs_cplx(c, s);   /* the parts named first: the instructions the float * writes gave (x86-64, -O3) */
}

/* e^{j x} for an angle that is mostly small (a step's turn, a compensation
 * angle), inline: where |x| < 0.78 fs_cis's quadrant is 0, its reduction
 * leaves r = x and r_lo = +0, and this is its result bit for bit without
 * the call and the reduction (some 30 instructions of 60 on a Cortex-M4F;
 * test_trig.c compares the two); elsewhere fs_cis itself. */
static inline float _Complex fs_cis_small(float x)
{
    if (!(fabsf(x) < 0.78f)) { return fs_cis(x); }
    /* fs_cis_poly(x, +0) without the tail's terms: x +0 and +0 w are
     * zeros the compiler must keep (x could be a NaN, a sum -0), and
     * adding them changes no result here (a zero sine is x's, below) */
    const float z = x * x, hz = 0.5f * z, w = 1.0f - hz;
    const float c = w + (((1.0f - w) - hz) + z * z * fs_cis_qc(z));
    const float s = x + x * z * fs_cis_qs(z);
    float _Complex e = fs_cplx(c, s);   /* so, not fs_cplx(c, s != 0 ? s : x): the instructions as before */
    if (s == 0.0f) { e = fs_cplx(c, x); }   /* sin(-0) = -0, as fs_cis */
    return e;
}

/* within 3 ulp where the inits use it (|x| < 1.5: test_trig.c) */
static inline float fs_tanf(float x) { return fs_sinf(x) / fs_cosf(x); }

/* atan2f and atanf, the same float32 on every platform (fs_transforms.c):
 * within 1.6 ulp of the exact value, 89 % of results correctly rounded */
float fs_atan2f(float y, float x) FS_CONST;
static inline float fs_atanf(float x) { return fs_atan2f(x, 1.0f); }

/* fmaxf and fminf, inline: the larger (smaller) of two, the number where
 * one is NaN, a where they are equal (as glibc's: -0 and +0 are equal). A
 * Cortex-M4F's FPU has no max instruction, and newlib's fmaxf is a call
 * that classifies both arguments: some 25 instructions against 5. */
static inline float fs_maxf(float a, float b) { return (a >= b || b != b) ? a : b; }
static inline float fs_minf(float a, float b) { return (a <= b || b != b) ? a : b; }

static inline float fs_clampf(float x, float lo, float hi)
{
    return x < lo ? lo : (x > hi ? hi : x);
}

/* fs_clampf(x, -L, L), the same result for every x and L, with one
 * comparison where x is inside (the common case of a limit) */
static inline float fs_clamp_sym(float x, float L)
{
    return fabsf(x) <= L ? x : fs_clampf(x, -L, L);
}

/* fs_clampf(x, 0, 1) (a duty, a weight), the same result for every x, with
 * one integer comparison where x is inside: the binary32 encodings of +0
 * to 1 are the integers 0 to 0x3f800000 (-0, negatives and NaN lie above) */
static inline float fs_clamp01(float x)
{
    const union { float f; uint32_t u; } b = {x};
    return b.u <= 0x3f800000u ? x : fs_clampf(x, 0.0f, 1.0f);
}

static inline float fs_signf(float x)
{
    return (x > 0.0f) ? 1.0f : ((x < 0.0f) ? -1.0f : 0.0f);
}

#endif /* FS_MATH_H */
