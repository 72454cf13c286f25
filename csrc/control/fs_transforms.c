#include "fs_transforms.h"
#include "fs_math.h"

fs_ab fs_clarke(float x_a, float x_b, float x_c)
{
    fs_ab y;
    y.alpha = (2.0f * x_a - x_b - x_c) * (1.0f / 3.0f);
    y.beta = (x_b - x_c) * FS_INV_SQRT3;
    return y;
}

void fs_inv_clarke(fs_ab x, float x_abc[3])
{
    x_abc[0] = x.alpha;
    x_abc[1] = -0.5f * x.alpha + 0.5f * FS_SQRT3 * x.beta;
    x_abc[2] = -0.5f * x.alpha - 0.5f * FS_SQRT3 * x.beta;
}

fs_dq fs_park(fs_ab x, float cos_theta, float sin_theta)
{
    fs_dq y;
    y.d = cos_theta * x.alpha + sin_theta * x.beta;
    y.q = -sin_theta * x.alpha + cos_theta * x.beta;
    return y;
}

fs_ab fs_inv_park(fs_dq x, float cos_theta, float sin_theta)
{
    fs_ab y;
    y.alpha = cos_theta * x.d - sin_theta * x.q;
    y.beta = sin_theta * x.d + cos_theta * x.q;
    return y;
}

static float _Complex cis(float c, float s)
{
    float _Complex e;
    ((float *)&e)[0] = c;
    ((float *)&e)[1] = s;
    return e;
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
    const float P1 = 1.5707855225f, P2 = 1.0804273188e-05f, P34 = 6.0771006283e-11f;
    const float M = 12582912.0f;   /* 1.5 2^23: x + M - M rounds x to an integer, for |x| < 2^22 */
    const float x = theta;
    if (!(fabsf(x) < 199.0f)) return cis_far(x);   /* k would need more than 7 bits */
    const float k = (x * 0.636619772f + M) - M;
    const float t = x - k * P1;                              /* exact */
    const float r = t - k * P2;
    const float r_lo = ((t - r) - k * P2) - k * P34;         /* what r lost */
    const float z = r * r, hz = 0.5f * z, w = 1.0f - hz;
    const float s = r + (r * z * (-0.16666655f + z * (0.00833216f + z * -0.00019515282f)) + r_lo * w);
    const float c = w + (((1.0f - w) - hz) + (z * z * (0.041666646f + z * (-0.0013887316f + z * 2.4433157e-05f)) - r * r_lo));
    switch ((int)k & 3) {
    case 0: return cis(c, s != 0.0f ? s : x);   /* sin(-0) = -0 */
    case 1: return cis(-s, c);
    case 2: return cis(-c, -s);
    default: return cis(s, -c);
    }
}

/* fs_cis beyond |theta| < 199 rad: wrapped first (out of line, so that the
 * common path needs no stack frame) */
FS_OUT_OF_LINE float _Complex cis_far(float theta)
{
    if (!(fabsf(theta) < INFINITY)) return cis(theta - theta, theta - theta);   /* NaN, as sinf and cosf */
    return fs_cis(fs_wrap_pi(theta));
}
