#include "fs_xcomp.h"
#include "fs_math.h"

fs_status fs_xcomp_check(const fs_xcomp_config *c)
{
    fs_status ret = FS_OK;
    if (!c) { ret = FS_ERR_NULL; }
    else {
        for (int k = 0; (k < 4) && (ret == FS_OK); ++k) {
            if (!isfinite(c->poly[k])) { ret = FS_ERR_PARAM; }
        }
        if ((ret != FS_OK) || (c->n == 0)) { /* refused, or no table to check */ }
        else if ((c->n < 2) || (c->n > FS_XCOMP_MAX) || !(c->di_q > 0.0f) || !isfinite(c->di_q) || !isfinite(c->i_q0)) {
            ret = FS_ERR_PARAM;
        }
        else {
            for (int k = 0; (k < c->n) && (ret == FS_OK); ++k) {
                if (!(fabsf(c->delta[k]) < (0.5f * FS_PI))) { ret = FS_ERR_PARAM; }
            }
        }
    }
    return ret;
}

bool fs_xcomp_active(const fs_xcomp_config *c)
{
    bool ret;
    if (!c) { ret = false; }
    else {
        ret = (c->n >= 2) || (c->poly[0] != 0.0f) || (c->poly[1] != 0.0f) || (c->poly[2] != 0.0f) || (c->poly[3] != 0.0f);
    }
    return ret;
}

float fs_xcomp_eval(const fs_xcomp_config *c, float i_q)
{
    float ret;
    if (!c || !isfinite(i_q)) { ret = 0.0f; }
    /* a table fs_xcomp_check refuses is not read (its indices would leave delta[]) */
    else if ((c->n > FS_XCOMP_MAX) || ((c->n >= 2) && !((c->di_q > 0.0f) && isfinite(c->di_q) && isfinite(c->i_q0)))) {
        ret = 0.0f;
    }
    else if (c->n < 2) {
        const float *p = c->poly;
        float d = p[0] + (i_q * (p[1] + (i_q * (p[2] + (i_q * p[3])))));   /* Horner */
        ret = fs_clampf(d, -0.5f * FS_PI, 0.5f * FS_PI);
    }
    else {
        const int n_last = c->n - 1;
        float x = fs_clampf((i_q - c->i_q0) / c->di_q, 0.0f, (float)n_last);
        int k = (int)x;
        if (k > (c->n - 2)) { k = c->n - 2; }
        float s = x - (float)k;
        ret = c->delta[k] + (s * (c->delta[k + 1] - c->delta[k]));
    }
    return ret;
}
