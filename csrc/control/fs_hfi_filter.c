#include "fs_hfi_filter.h"
#include "fs_math.h"

#include <stddef.h>

FS_COLD fs_status fs_hfi_filter_init(fs_hfi_filter *f, const fs_hfi_filter_config *cfg)
{
    if (!f || !cfg) { return FS_ERR_NULL; }
    fs_srff_config c = {cfg->Ts, cfg->w_b_p};
    fs_status st = fs_srff_init(&f->srff_p, &c);
    if (st != FS_OK) { return st; }
    c.w_b = cfg->w_b_n;
    st = fs_srff_init(&f->srff_n, &c);
    if (st != FS_OK) { return st; }
    f->leak_n = f->srff_n;
    f->leak_p = f->srff_p;
    f->cfg = *cfg;
    fs_hfi_filter_reset(f);
    return FS_OK;
}

void fs_hfi_filter_reset(fs_hfi_filter *f)
{
    fs_srff_reset(&f->srff_p);
    fs_srff_reset(&f->srff_n);
    fs_srff_reset(&f->leak_p);
    fs_srff_reset(&f->leak_n);
}

void fs_hfi_filter_step(fs_hfi_filter *f, fs_ab i, float theta_h, float theta_r_hat,
                        fs_ab *i_f, fs_ab *i_hn)
{
    const float theta_n = fs_wrap_pi(2.0f * theta_r_hat - theta_h);
    const fs_ab e_h = {fs_cosf(theta_h), fs_sinf(theta_h)}, e_n = {fs_cosf(theta_n), fs_sinf(theta_n)};
    fs_hfi_filter_step_cs(f, i, e_h, e_n, i_f, i_hn);
}

void fs_hfi_filter_step_cs(fs_hfi_filter *f, fs_ab i, fs_ab e_h, fs_ab e_n, fs_ab *i_f, fs_ab *i_hn)
{
    /* Fig. 4b: remove the positive carrier at w_h ... */
    fs_ab y = fs_srff_step_cs(&f->srff_p, i, e_h.alpha, e_h.beta);
    /* ... then the negative carrier at -w_h + 2 w_r_hat, eq. (24). */
    fs_ab fund = fs_srff_step_cs(&f->srff_n, y, e_n.alpha, e_n.beta);
    if (i_f != NULL) { *i_f = fund; }
    if (i_hn != NULL) {
        i_hn->alpha = y.alpha - fund.alpha;
        i_hn->beta = y.beta - fund.beta;
    }
}

void fs_hfi_filter_step_nl(fs_hfi_filter *f, fs_ab i, fs_ab e_h, fs_ab e_n, fs_ab *i_f, fs_ab *i_hn)
{
    fs_ab i_fund, hn;
    fs_hfi_filter_step_cs(f, i, e_h, e_n, &i_fund, &hn);
    /* (1 - H_n) H_p on the fundamental: the leak i_hn carries */
    const fs_ab y = fs_srff_step_cs(&f->leak_p, i_fund, e_h.alpha, e_h.beta);
    const fs_ab yn = fs_srff_step_cs(&f->leak_n, y, e_n.alpha, e_n.beta);
    if (i_f != NULL) { *i_f = i_fund; }
    if (i_hn != NULL) {
        i_hn->alpha = hn.alpha - (y.alpha - yn.alpha);
        i_hn->beta = hn.beta - (y.beta - yn.beta);
    }
}
