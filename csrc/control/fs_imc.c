#include "fs_imc.h"
#include "fs_math.h"
#include "fs_transforms.h"

static const float ALPHA_MAX = FS_PI / 6.0f;

float fs_imc_vpn(float alpha)
{
    float a = fs_clampf(alpha, 0.0f, ALPHA_MAX);
    /* eq. (12) */
    return 9.0f / FS_PI * (logf(fs_tanf((FS_PI / 3.0f) - (0.5f * a))) + (2.0f * FS_INV_SQRT3 * fs_sinf(a)));
}

float fs_imc_vtr_max(int region, float alpha)
{
    float ret;
    if (region == (int)FS_IMC_LINEAR) { ret = 0.5f * FS_SQRT3; }
    else {
        /* eq. (20): line fundamental 3 ln3 / pi V_pn; eq. (21): phase over V_im */
        ret = 3.0f * logf(3.0f) / FS_PI * fs_imc_vpn((region == (int)FS_IMC_OM1) ? 0.0f : alpha) * FS_INV_SQRT3;
    }
    return ret;
}

int fs_imc_region_of(float q)
{
    int ret;
    if (q <= fs_imc_vtr_max(FS_IMC_LINEAR, 0.0f)) { ret = FS_IMC_LINEAR; }
    else if (q <= fs_imc_vtr_max(FS_IMC_OM1, 0.0f)) { ret = FS_IMC_OM1; }
    else {
        ret = FS_IMC_OM2;
    }
    return ret;
}

float fs_imc_alpha_for_vtr(float q)
{
    float ret;
    if (!(q > fs_imc_vtr_max(FS_IMC_OM1, 0.0f))) { ret = 0.0f; }
    else if (q >= fs_imc_vtr_max(FS_IMC_OM2, ALPHA_MAX)) { ret = ALPHA_MAX; }
    else {
        /* eq. (12) rises monotonically on [0, pi/6]: bisection */
        float lo = 0.0f;
        float hi = ALPHA_MAX;
        for (int k = 0; k < 24; ++k) {
            float mid = 0.5f * (lo + hi);
            if (fs_imc_vtr_max(FS_IMC_OM2, mid) < q) { lo = mid; } else { hi = mid; }
        }
        ret = 0.5f * (lo + hi);
    }
    return ret;
}

float fs_imc_amplitude(const float u_in[3])
{
    fs_ab u = fs_clarke(u_in[0], u_in[1], u_in[2]);
    return sqrtf((u.alpha * u.alpha) + (u.beta * u.beta));
}

/* Fig. 3a from the phases' order, without the input angle: the largest
 * and the smallest phase fix a sixth of the cycle (sector 1 and 2: a max,
 * c min; 3 and 4: b, c; ...), and whether the phase of largest magnitude x
 * is the largest or the smallest picks its half (x = the largest in sector 1,
 * then alternating from pair to pair). */
static int rect_sector(int hi, int lo, int x)
{
    static const signed char pair[3][3] = {{-1, 5, 0}, {2, -1, 1}, {3, 4, -1}};   /* [hi][lo] */
    const int k = pair[hi][lo];
    const int first = ((k % 2) == 0) ? hi : lo;
    return (2 * k) + 1 + ((x != first) ? 1 : 0);
}

void fs_imc_rectifier(const float u_in[3], float alpha, fs_imc_rect *r)
{
    /* x: largest magnitude; hi, mid, lo by value */
    int x = 0;
    for (int k = 1; k < 3; ++k) { if (fabsf(u_in[k]) > fabsf(u_in[x])) { x = k; } }
    int hi = 0;
    int lo = 0;
    for (int k = 1; k < 3; ++k) {
        if (u_in[k] > u_in[hi]) { hi = k; }
        if (u_in[k] < u_in[lo]) { lo = k; }
    }
    if (hi == lo) { lo = (hi + 1) % 3; }   /* all equal (zero input) */
    int mid = 3 - hi - lo;
    const float ux = u_in[x];
    const float v_max = u_in[hi] - u_in[lo];
    r->sector = rect_sector(hi, lo, x);

    /* CASE 2 within alpha of the middle phase's zero crossing (eq. (11)):
     * |u_mid| < V_im sin(alpha), squared, with V_im^2 = 2/3 sum(u^2) */
    const float s = fs_sinf(fs_clampf(alpha, 0.0f, ALPHA_MAX));
    const float sum2 = (u_in[0] * u_in[0]) + (u_in[1] * u_in[1]) + (u_in[2] * u_in[2]);
    r->case2 = (u_in[mid] * u_in[mid]) < s * s * (2.0f / 3.0f) * sum2 || fabsf(ux) < 1e-6f;
    r->iv[0].p = hi;
    r->iv[0].n = lo;
    if (r->case2) {                         /* eqs. (7)-(8) */
        r->iv[0].d = 1.0f;
        r->iv[1] = r->iv[0];
        r->iv[1].d = 0.0f;
        r->v_pn = v_max;
    }
    else {
        /* eqs. (4)-(6): x on its rail, the other on the far phase, then on mid */
        const float d_far = fs_clamp01(-u_in[(x == hi) ? lo : hi] / ux);
        r->iv[0].d = d_far;
        r->iv[1].p = (x == hi) ? hi : mid;
        r->iv[1].n = (x == hi) ? mid : lo;
        r->iv[1].d = 1.0f - d_far;
        const float v_mid = u_in[r->iv[1].p] - u_in[r->iv[1].n];
        r->v_pn = (d_far * v_max) + (r->iv[1].d * v_mid);
    }
}

FS_COLD fs_status fs_imc_depth_design(fs_imc_depth_config *cfg, float Ts, float i_lim, float V_im,
                              float w_e_max, float L, float bw)
{
    fs_status ret;
    if (!cfg) { ret = FS_ERR_NULL; }
    else if (!fs_pos(Ts)) { ret = FS_ERR_TS; }
    else if (!fs_pos(V_im) || !fs_pos(w_e_max)) { ret = FS_ERR_LIMIT; }
    else if (!fs_pos(L)) { ret = FS_ERR_LD; }
    else if (!(bw > 0.0f) || !((bw * Ts) <= 1.0f)) { ret = FS_ERR_BANDWIDTH; }
    else if (!fs_pos(i_lim)) { ret = FS_ERR_I_MAX; }
    else {
        float dq = fs_imc_vtr_max(FS_IMC_OM2, ALPHA_MAX) - fs_imc_vtr_max(FS_IMC_OM2, 0.0f);
        float G = dq / ALPHA_MAX * V_im / (w_e_max * L);   /* A/rad */
        cfg->Ts = Ts;
        cfg->i_lim = i_lim;
        cfg->k_i = bw / G;
        cfg->k_p = 0.5f / G;
        ret = fs_fin(cfg->k_i) ? FS_OK : FS_ERR_PARAM;   /* G = 0: V_im / (w_e,max L) below the float range */
    }
    return ret;
}

FS_COLD fs_status fs_imc_depth_init(fs_imc_depth *dc, const fs_imc_depth_config *cfg)
{
    fs_status ret;
    if (!dc || !cfg) { ret = FS_ERR_NULL; }
    else if (!fs_pos(cfg->Ts)) { ret = FS_ERR_TS; }
    else if (!fs_pos(cfg->i_lim)) { ret = FS_ERR_I_MAX; }
    else if (!fs_nonneg(cfg->k_p) || !fs_nonneg(cfg->k_i)) { ret = FS_ERR_PARAM; }
    else {
        dc->cfg = *cfg;
        fs_imc_depth_reset(dc);
        ret = FS_OK;
    }
    return ret;
}

void fs_imc_depth_reset(fs_imc_depth *dc)
{
    dc->integ = 0.0f;
    dc->alpha = 0.0f;
}

float fs_imc_depth_step(fs_imc_depth *dc, float i_ref, bool weakening)
{
    float ret;
    const fs_imc_depth_config *c = &dc->cfg;
    if (!weakening || !isfinite(i_ref)) {   /* sec. 4.4: the polarity gate */
        fs_imc_depth_reset(dc);
        ret = 0.0f;
    }
    else {
        float e = i_ref - c->i_lim;
        dc->integ = fs_clampf(dc->integ + (c->Ts * c->k_i * e), 0.0f, ALPHA_MAX);   /* eq. (33) */
        dc->alpha = fs_clampf((c->k_p * e) + dc->integ, 0.0f, ALPHA_MAX);
        ret = dc->alpha;
    }
    return ret;
}
