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
