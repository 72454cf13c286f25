#include "fs_srff.h"
#include "fs_math.h"

FS_COLD fs_status fs_srff_init(fs_srff *f, const fs_srff_config *cfg)
{
    fs_status ret;
    if (!f || !cfg) { ret = FS_ERR_NULL; }
    else if (!(cfg->Ts > 0.0f) || !isfinite(cfg->Ts)) { ret = FS_ERR_TS; }
    else if (!(cfg->w_b > 0.0f) || !((cfg->w_b * cfg->Ts) <= 0.5f)) { ret = FS_ERR_BANDWIDTH; }
    else {
        f->cfg = *cfg;
        f->a = fs_exp_pole(-cfg->w_b * cfg->Ts);  /* pole of w_b / (s + w_b), held input */
        f->b = 1.0f - f->a;
        f->g = 0.5f * (1.0f + f->a);       /* low-pass read mid-period */
        fs_srff_reset(f);
        ret = FS_OK;
    }
    return ret;
}

void fs_srff_reset(fs_srff *f) { f->lp.d = 0.0f; f->lp.q = 0.0f; }

fs_ab fs_srff_step(fs_srff *f, fs_ab x, float theta_x)
{
    return fs_srff_step_cs(f, x, fs_cosf(theta_x), fs_sinf(theta_x));
}

fs_ab fs_srff_step_cs(fs_srff *f, fs_ab x, float c, float s)
{
    /* Fig. 4a: in the frame at theta_x, x_r - lp (lp at the start of the
     * period); rotated back, d = x - e^{j theta_x} lp. */
    fs_ab lp = fs_inv_park(f->lp, c, s);
    fs_ab d;
    d.alpha = x.alpha - lp.alpha;
    d.beta = x.beta - lp.beta;
    /* Low-pass in the frame, exact for a held input: lp += (1 - a)(x_r - lp). */
    fs_dq dr = fs_park(d, c, s);
    f->lp.d += f->b * dr.d;
    f->lp.q += f->b * dr.q;
    /* x minus the average of lp at the start and end of the period:
     * (1 + a)/2 d, eq. (25) (bilinear image, see fs_srff.h). */
    fs_ab y;
    y.alpha = f->g * d.alpha;
    y.beta = f->g * d.beta;
    return y;
}
