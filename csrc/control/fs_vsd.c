#include "fs_vsd.h"

/* cos, sin of k g and of 3 k g, g = 2 pi / 5, k = 0..4 (3 k g = 0, 216, 72,
 * 288, 144 degrees: the x-y plane visits the phases in the order A D B E C). */
static const float cos_1[5] = {1.0f, 0.309016994f, -0.809016994f, -0.809016994f, 0.309016994f};
static const float sin_1[5] = {0.0f, 0.951056516f, 0.587785252f, -0.587785252f, -0.951056516f};
static const float cos_3[5] = {1.0f, -0.809016994f, 0.309016994f, 0.309016994f, -0.809016994f};
static const float sin_3[5] = {0.0f, -0.587785252f, 0.951056516f, -0.951056516f, 0.587785252f};

fs_vsd5 fs_vsd5_forward(const float x[5])
{
    fs_vsd5 v = {{0.0f, 0.0f}, {0.0f, 0.0f}, 0.0f};
    for (int k = 0; k < 5; ++k) {
        v.ab.alpha += x[k] * cos_1[k];
        v.ab.beta += x[k] * sin_1[k];
        v.xy.alpha += x[k] * cos_3[k];
        v.xy.beta += x[k] * sin_3[k];
        v.zero += x[k];
    }
    v.ab.alpha *= 0.4f;
    v.ab.beta *= 0.4f;
    v.xy.alpha *= 0.4f;
    v.xy.beta *= 0.4f;
    v.zero *= 0.2f;
    return v;
}

void fs_vsd5_inverse(const fs_vsd5 *v, float x[5])
{
    for (int k = 0; k < 5; ++k) {
        x[k] = (v->ab.alpha * cos_1[k]) + (v->ab.beta * sin_1[k]) + (v->xy.alpha * cos_3[k]) + (v->xy.beta * sin_3[k])
               + v->zero;
    }
}
