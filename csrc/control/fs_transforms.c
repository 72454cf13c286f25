#include "fs_transforms.h"
#include "fs_math.h"

fs_ab fs_clarke(float x_a, float x_b, float x_c)
{
    fs_ab y;
    y.alpha = ((2.0f * x_a) - x_b - x_c) * (1.0f / 3.0f);
    y.beta = (x_b - x_c) * FS_INV_SQRT3;
    return y;
}

void fs_inv_clarke(fs_ab x, float x_abc[3])
{
    x_abc[0] = x.alpha;
    x_abc[1] = (-0.5f * x.alpha) + (0.5f * FS_SQRT3 * x.beta);
    x_abc[2] = (-0.5f * x.alpha) - (0.5f * FS_SQRT3 * x.beta);
}

fs_dq fs_park(fs_ab x, float cos_theta, float sin_theta)
{
    fs_dq y;
    y.d = (cos_theta * x.alpha) + (sin_theta * x.beta);
    y.q = (-sin_theta * x.alpha) + (cos_theta * x.beta);
    return y;
}

fs_ab fs_inv_park(fs_dq x, float cos_theta, float sin_theta)
{
    fs_ab y;
    y.alpha = (cos_theta * x.d) - (sin_theta * x.q);
    y.beta = (sin_theta * x.d) + (cos_theta * x.q);
    return y;
}

/* The quadrant k = round(theta 2/pi) and r = theta - k pi/2 in |r| <= pi/4,
 * then polynomials on r (weighted minimax fits on |r| <= pi/4, for float32:
 * within 0.06 ulp of the sine, 0.002 of the cosine) and the quadrant's
 * swap of the pair.
 *
 * Why not sinf and cosf: a Cortex-M4F's newlib reduces the argument afresh
 * in each call (a third of the blended drive step went to them, both
 * called on the same angle), and host and target libms differ by an ulp on
 * a tenth of the arguments; this is the same IEEE binary32 arithmetic on
 * both. Accuracy: pi/2 is split in parts whose products with |k| < 128 are
 * exact (the first with 17 significant bits, so theta - k P1 is exact by
 * Sterbenz), the rounding of r - k P2 is carried as a tail r_lo into both
 * polynomials, and the cosine's 1 - r^2/2 keeps its rounding error: the
 * results are faithfully rounded (at most 1 ulp from the exact value; 96 %
 * of arguments in (-4, 4) correctly rounded, as 98.5 % of glibc's). */
FS_OUT_OF_LINE float _Complex cis_far(float theta);

float _Complex fs_cis(float theta)
{
    /* pi/2 = P1 + P2 + P34: its first 17 significant bits, the next 17, the rest */
    const float P1 = 1.5707855225f;
    const float P2 = 1.0804273188e-05f;
    const float P34 = 6.0771006283e-11f;
    const float M = 12582912.0f;   /* 1.5 2^23: x + M - M rounds x to an integer, for |x| < 2^22 */
    const float x = theta;
    if (!(fabsf(x) < 199.0f)) { return cis_far(x); }   /* k would need more than 7 bits */
    const float k = ((x * 0.636619772f) + M) - M;
    const float t = x - (k * P1);                              /* exact */
    const float r = t - (k * P2);
    const float r_lo = ((t - r) - (k * P2)) - (k * P34);         /* what r lost */
    const float _Complex e = fs_cis_poly(r, r_lo);
    const float c = fs_cre(e);
    const float s = fs_cim(e);
    switch ((int)k & 3) {
    case 0: return fs_cplx(c, (s != 0.0f) ? s : x);   /* sin(-0) = -0 */
    case 1: return fs_cplx(-s, c);
    case 2: return fs_cplx(-c, -s);
    default: return fs_cplx(s, -c);
    }
}

/* fs_cis beyond |theta| < 199 rad: wrapped first (out of line, so that the
 * common path needs no stack frame) */
FS_OUT_OF_LINE float _Complex cis_far(float theta)
{
    float _Complex ret;
    if (!(fabsf(theta) < INFINITY)) { ret = fs_cplx(theta - theta, theta - theta); }   /* NaN, as sinf and cosf */
    else {
        ret = fs_cis(fs_wrap_pi(theta));
    }
    return ret;
}

/* atan(y/x) in the quadrant of (x, y), as atan2f (its zeros, infinities and
 * NaN included). Reduced to t = min/max(|x|, |y|) in [0, 1] (the rest by
 * pi/2 - and pi -), and for t >= 1/2 to u = (t - 1)/(t + 1) around pi/4,
 * formed from the numerator and denominator themselves (their difference
 * exact by Sterbenz): |u| <= 1/2, where atan(u) = u + u^3 P(u^2), a weighted
 * minimax fit (0.09 ulp); pi/4, pi/2 and pi are added as two parts each,
 * with the sum's rounding error carried (Fast2Sum). Within 1.6 ulp of the
 * exact value, over 1 ulp on 0.06 % of arguments, correctly rounded on 89 %
 * (glibc's atan2f on 84 %): the division's rounding is what is left. */
float fs_atan2f(float y, float x)
{
    const float PI4_HI = 7.85398185e-01f;                              /* pi/4 = HI + LO */
    const float PI4_LO = -2.18556941e-08f;
    const float PI2_HI = 1.57079637e+00f;
    const float PI2_LO = -4.37113883e-08f;
    const float PI_HI = 3.14159274e+00f;
    const float PI_LO = -8.74227766e-08f;
    const float ax = fabsf(x);
    const float ay = fabsf(y);
    const bool swap = ay > ax;
    float num = swap ? ax : ay;                         /* num <= den (or a NaN) */
    float den = swap ? ay : ax;
    float u;
    float hi;
    float lo;
    if (!((num > 0.0f) && (den < 1e38f))) {   /* zeros, infinities, NaN; num + den could overflow */
        if ((num != num) || (den != den)) { return x + y; }
        if (den == INFINITY) {
            num = (num == INFINITY) ? 1.0f : 0.0f;
            den = 1.0f;
        } else if (num > 0.0f) {
            num *= 0.25f;
            den *= 0.25f;
        } else {
            den = 1.0f;   /* 0/0 and 0/x: the angle 0, then the quadrant */
        }
    }
    if (num >= (0.5f * den)) {
        u = (num - den) / (num + den);
        hi = PI4_HI;
        lo = PI4_LO;
    } else {
        u = num / den;
        hi = 0.0f;
        lo = 0.0f;
    }
    const float z = u * u;
    const float p = u * z * (-0.33333233f + (z * (0.19994226f + (z * (-0.14175011f + (z * (0.10160015f + (z * -0.05132597f))))))));
    const float s1 = hi + u;                       /* exact: |hi| >= |u| or hi = 0 */
    const float e1 = (hi - s1) + u;
    float a;
    if (swap) {   /* pi/2 - the angle */
        const float s2 = PI2_HI - s1;
        const float e2 = (PI2_HI - s2) - s1;
        a = s2 + (e2 + (PI2_LO - (e1 + (lo + p))));
    } else {
        a = s1 + (e1 + (lo + p));
    }
    if (signbit(x) != 0) {   /* pi - the angle */
        const float s3 = PI_HI - a;
        const float e3 = (PI_HI - s3) - a;
        a = s3 + (e3 + PI_LO);
    }
    return copysignf(a, y);
}
