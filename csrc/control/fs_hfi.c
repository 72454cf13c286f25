#include "fs_hfi.h"
#include "fs_math.h"
#include <float.h>

/* The heterodyne reference's rotation phi_ref and the negative carrier's
 * amplitude for the stator resistance R_s (h->cfg holds the rest). */
static void carrier_phase(fs_hfi *h, float R_s)
{
    const fs_hfi_config c = h->cfg;
    const float x = 0.5f * c.w_h * c.Ts, sinc = fs_sinf(x) / x;
    /* the first SRFF's phase on the negative carrier, 2 w_h below its stop
     * band (the bilinear images of fs_srff.h) */
    const float w_b = (2.0f / c.Ts) * tanhf(0.5f * c.w_b_p * c.Ts);
    const float v = (2.0f / c.Ts) * fs_tanf(c.w_h * c.Ts);
    const float phi_p = fs_atanf(w_b / v);
    /* the resistance's phase on the negative carrier, with the held
     * voltage's R x cot x (header) */
    const float sl = 0.5f * (c.L_d + c.L_q), dl = 0.5f * (c.L_d - c.L_q);
    const float R = R_s * x / fs_tanf(x), w = c.w_h;
    const float D_re = w * w * (sl * sl - dl * dl) - R * R, D_im = 2.0f * R * w * sl;
    const float phi_r = fs_atan2f(D_im, D_re);
    h->phi_ref = 0.5f * FS_PI - phi_p - phi_r;
    if (dl > 0.0f) { h->phi_ref -= FS_PI; }   /* L_d > L_q: the carrier of eq. (24) changes sign */
    /* the negative carrier's amplitude, |B| of the header, at the samples */
    h->i_n_design = c.u_h * w * fabsf(dl) / sqrtf(D_re * D_re + D_im * D_im) / (sinc * sinc);
    h->rot_ref.alpha = fs_cosf(h->phi_ref);
    h->rot_ref.beta = fs_sinf(h->phi_ref);
    h->cfg.R_s = R_s;
}

void fs_hfi_set_resistance(fs_hfi *h, float R_s)
{
    if (h && fs_nonneg(R_s)) { carrier_phase(h, R_s); }
}

/* nextafterf(w, 0) for w > 0 (an infinity included), without libm's
 * nextafterf (128 B of the production image): for a normal w in
 * [2^e, 2^(e+1)), w 2^-24 is exact and lies in [1/2, 1) of w's ulp, so
 * w - w 2^-24 rounds to the float one below (at w = 2^e it is that float
 * exactly); an infinity steps down to the largest float */
static float next_down(float w)
{
    return (w < INFINITY) ? (w - (w * 5.9604644775390625e-8f)) : FLT_MAX;
}

float fs_hfi_w_h_max(float Ts)
{
    /* beyond FS_HFI_TS_MAX, w 2^-24 would be subnormal: next_down would not step and the search would not end */
    if (!fs_pos(Ts) || !(Ts <= FS_HFI_TS_MAX)) { return 0.0f; }
    float w = 0.5f * FS_PI / Ts;
    while (w > 0.0f && !(w * Ts < 0.5f * FS_PI)) { w = next_down(w); }
    return w;
}

FS_COLD fs_status fs_hfi_init(fs_hfi *h, const fs_hfi_config *cfg)
{
    if (!h || !cfg) { return FS_ERR_NULL; }
    fs_hfi_config c = *cfg;
    if (!fs_pos(c.Ts) || !(c.Ts <= FS_HFI_TS_MAX)) { return FS_ERR_TS; }
    if (!(c.delay >= 0.0f && c.delay <= 2.0f)) { return FS_ERR_PARAM; }
    if (!fs_pos(c.u_h)) { return FS_ERR_PARAM; }
    if (c.leak != 0 && c.leak != 1) { return FS_ERR_PARAM; }
    if (c.lag != 0 && c.lag != 1) { return FS_ERR_PARAM; }
    if (!(c.w_h > 0.0f) || !(c.w_h <= fs_hfi_w_h_max(c.Ts))) { return FS_ERR_BANDWIDTH; }
    if (!fs_nonneg(c.w_b_p) || !fs_nonneg(c.w_b_n)) { return FS_ERR_BANDWIDTH; }
    if (!fs_nonneg(c.R_s)) { return FS_ERR_RS; }
    if (!fs_pos(c.L_d)) { return FS_ERR_LD; }
    if (!fs_pos(c.L_q)) { return FS_ERR_LQ; }
    if (!(fabsf(c.L_q - c.L_d) > 0.01f * 0.5f * (c.L_d + c.L_q))) { return FS_ERR_SALIENCY; }
    if (c.w_b_p == 0.0f) { c.w_b_p = 0.05f * c.w_h; }
    if (c.w_b_n == 0.0f) { c.w_b_n = 0.05f * c.w_h; }
    /* the settling count 3 / (w_b_n Ts) must stay an int */
    if (!(c.w_b_n * c.Ts >= 1e-4f)) { return FS_ERR_BANDWIDTH; }
    if (c.obs.bandwidth == 0.0f) { c.obs.bandwidth = (c.lag ? FS_HFI_OBS_PER_FILTER_LAG : FS_HFI_OBS_PER_FILTER) * c.w_b_n; }
    c.obs.Ts = c.Ts;

    if (fs_xcomp_check(&c.xcomp) != FS_OK) { return FS_ERR_PARAM; }
    fs_hfi_filter_config fc = {c.Ts, c.w_b_p, c.w_b_n};
    fs_status st = fs_hfi_filter_init(&h->filt, &fc);
    if (st != FS_OK) { return st; }
    /* with lag: eq. (26)'s error comes through the second SRFF's low-pass, twice with the leak's removal */
    st = fs_motion_obs_init_lag(&h->obs, &c.obs, c.lag ? 1 + c.leak : 0, c.lag ? c.w_b_n : 0.0f);
    if (st != FS_OK) { return st; }
    h->cfg = c;

    const float x = 0.5f * c.w_h * c.Ts, sinc = fs_sinf(x) / x;
    h->dtheta_h = c.w_h * c.Ts;
    h->theta_u = c.w_h * c.Ts * (c.delay + 0.5f);
    h->u_amp = c.u_h / sinc;                        /* the held staircase's component at w_h is eq. (22) */
    carrier_phase(h, c.R_s);
    if (!fs_pos(h->i_n_design) || !fs_fin(h->u_amp)) { return FS_ERR_PARAM; }   /* beyond the float range */
    h->k_avg = -expm1f(-0.25f * c.w_b_n * c.Ts);
    h->n_settle = fs_ceil_int(3.0f / (c.w_b_n * c.Ts));
    h->k_follow = -expm1f(-c.w_b_n * c.Ts);   /* fs_hfi_follow: the filters' bandwidth */
    h->w_o_blend = c.lag ? FS_HFI_OBS_PER_FILTER * c.w_b_n : c.obs.bandwidth;
    {   /* the table's i_q over a carrier period (header) */
        const float period_steps = (2.0f * FS_PI / (c.w_h * c.Ts)) + 0.5f;   /* rounded by the truncation to int */
        const int n = (int)period_steps;
        h->n_iq = n < FS_HFI_IQ_MAX ? n : FS_HFI_IQ_MAX;
        h->inv_n_iq = 1.0f / (float)h->n_iq;
    }
    if (c.lag != 0) {
        fs_motion_obs_config ow = c.obs;
        ow.bandwidth = h->w_o_blend;
        st = fs_motion_obs_init(&h->obs_w, &ow);
        if (st != FS_OK) { return st; }
    }
    h->rot_u.alpha = fs_cosf(h->theta_u);
    h->rot_u.beta = fs_sinf(h->theta_u);
    h->rot_h.alpha = fs_cosf(h->dtheta_h);
    h->rot_h.beta = fs_sinf(h->dtheta_h);
    fs_hfi_reset(h, 0.0f, 0.0f);
    return FS_OK;
}

FS_COLD void fs_hfi_reset(fs_hfi *h, float theta, float w)
{
    fs_hfi_filter_reset(&h->filt);
    fs_motion_obs_reset(&h->obs, theta, w);
    if (h->cfg.lag != 0) { fs_motion_obs_reset(&h->obs_w, theta, w); }
    h->theta_h = 0.0f;
    h->e_h.alpha = 1.0f;
    h->e_h.beta = 0.0f;
    h->k_h = 0;
    h->k_settle = h->n_settle;
    h->gain = h->gain_prev = 1.0f;
    h->unit_p.d = h->unit_p.q = 0.0f;
    h->unit_n = h->unit_p;
    h->i_f.alpha = h->i_f.beta = 0.0f;
    h->i_hn = h->i_f;
    h->ref = h->i_f;
    h->i_p = h->i_n = 0.0f;
    h->i_n_avg = h->i_n_design;
    h->eps = h->delta = h->i_q = h->iq_sum = 0.0f;
    for (int k = 0; k < FS_HFI_IQ_MAX; ++k) { h->iq_buf[k] = 0.0f; }
    h->k_iq = 0;
    h->theta = h->obs.theta_hat;
    h->w = h->cfg.lag ? h->obs_w.w_hat : h->obs.w_hat;
    h->u.alpha = h->u.beta = 0.0f;
}

FS_COLD void fs_hfi_restart(fs_hfi *h, float theta, float w)
{
    const fs_dq p = h->unit_p;
    const fs_dq n = h->unit_n;
    fs_hfi_reset(h, theta, w);
    h->unit_p = p;
    h->unit_n = n;
    fs_hfi_fade_in(h);
}

FS_COLD void fs_hfi_fade_in(fs_hfi *h)
{
    h->gain = 0.0f;
    h->gain_prev = 0.0f;
    h->k_settle = 2 * h->n_settle;
}

FS_COLD void fs_hfi_set_angle(fs_hfi *h, float theta, float w)
{
    fs_motion_obs_reset(&h->obs, theta, w);
    if (h->cfg.lag != 0) { fs_motion_obs_reset(&h->obs_w, theta, w); }
    h->theta = h->obs.theta_hat;
    h->w = h->cfg.lag ? h->obs_w.w_hat : h->obs.w_hat;
}

FS_COLD void fs_hfi_follow(fs_hfi *h, float theta, float w)
{
    /* a first-order follow at w_b_n on top of the prediction at w (header) */
    const float th = h->obs.theta_hat + (h->k_follow * fs_wrap_pi(theta - h->obs.theta_hat));
    fs_hfi_set_angle(h, th, w);
}

FS_COLD float fs_hfi_axis_error(const fs_hfi *h)
{
    const float cross = (h->ref.alpha * h->i_hn.beta) - (h->ref.beta * h->i_hn.alpha);
    const float dot = (h->ref.alpha * h->i_hn.alpha) + (h->ref.beta * h->i_hn.beta);
    return 0.5f * fs_atan2f(cross, dot);
}

void fs_hfi_set_load(fs_hfi *h, float T_d)
{
    h->obs.T_d_hat = T_d;
    if (h->cfg.lag != 0) { h->obs_w.T_d_hat = T_d; }
}

float fs_hfi_step(fs_hfi *h, fs_ab i, float T_ff)
{
    /* Both carriers are proportional to the injected amplitude: a change of
     * the gain adds the change of the carriers to the filters' states (a fade
     * would otherwise leave a residue of lag x slope in the fundamental). The
     * carriers per unit gain are those the states held at full gain. */
    if (h->gain != h->gain_prev) {
        if (h->gain_prev == 1.0f) {
            /* leaving gain 1: the carriers per unit gain are the states of
             * the last step at gain 1 (nothing moves them in between), with
             * cfg.leak less the fundamental's leak they also hold, its image
             * in leak_p and leak_n (the same SRFFs on the fundamental, the
             * same frames): that leak does not scale with the gain, and a
             * snapshot of it scaled with a fade moved the estimate (beside
             * 60 A, 1.7 A of carrier: the amplitude 380 % off, the angle 10
             * deg). Taken here rather than at every step at gain 1: the
             * same values, off the step's hot path */
            h->unit_p = h->filt.srff_p.lp;
            h->unit_n = h->filt.srff_n.lp;
            if (h->cfg.leak != 0) {
                h->unit_p.d -= h->filt.leak_p.lp.d;
                h->unit_p.q -= h->filt.leak_p.lp.q;
                h->unit_n.d -= h->filt.leak_n.lp.d;
                h->unit_n.q -= h->filt.leak_n.lp.q;
            }
        }
        const float dg = h->gain - h->gain_prev;
        h->filt.srff_p.lp.d += dg * h->unit_p.d;
        h->filt.srff_p.lp.q += dg * h->unit_p.q;
        h->filt.srff_n.lp.d += dg * h->unit_n.d;
        h->filt.srff_n.lp.q += dg * h->unit_n.q;
        /* the averaged amplitude follows the gain; from 0, or where the
         * ratio would take it beyond the float range (a gain rising from
         * 1e-38), it starts again from the design amplitude */
        const float avg = h->i_n_avg * (h->gain / h->gain_prev);
        h->i_n_avg = fs_fin(avg) ? avg : h->gain * h->i_n_design;
        h->gain_prev = h->gain;
    }
    const float theta_h = h->theta_h;
    const float theta_hat = h->obs.theta_hat;
    /* cross-saturation compensation (header): the saliency axis expected at
     * theta_hat + delta(i_q), i_q the fundamental's q current in the
     * estimated frame over the last carrier period (a running sum, summed
     * afresh once a period so that its rounding does not accumulate) */
    const float ct = fs_cosf(theta_hat), st = fs_sinf(theta_hat);
    h->delta = 0.0f;
    if (fs_xcomp_active(&h->cfg.xcomp)) {
        const float i_q = -h->i_f.alpha * st + h->i_f.beta * ct;
        h->iq_sum += i_q - h->iq_buf[h->k_iq];
        h->iq_buf[h->k_iq] = i_q;
        if (++h->k_iq == h->n_iq) {
            h->k_iq = 0;
            h->iq_sum = 0.0f;
            for (int k = 0; k < h->n_iq; ++k) { h->iq_sum += h->iq_buf[k]; }
        }
        h->i_q = h->iq_sum * h->inv_n_iq;
        h->delta = fs_xcomp_eval(&h->cfg.xcomp, h->i_q);
    }
    /* the carrier's frame and the negative carrier's, once per step, the
     * latter where the negative carrier is expected:
     * e^{j(2 (theta_hat + delta) - theta_h)} = (e^{j theta_hat})^2 conj(e_h)
     * e^{j 2 delta}, products rather than a second angle's cosine and sine */
    const float c2 = ct * ct - st * st, s2 = 2.0f * ct * st;
    const fs_ab e_h = h->e_h;
    fs_ab e_n = {c2 * e_h.alpha + s2 * e_h.beta, s2 * e_h.alpha - c2 * e_h.beta};
    if (h->delta != 0.0f) {   /* e^{j 2 delta} = (e^{j delta})^2: delta is a few degrees (fs_cis_small's short path), 2 delta often not */
        const float _Complex r = fs_cis_small(h->delta);
        const float rc = fs_cre(r), rs = fs_cim(r);
        e_n = fs_inv_park((fs_dq){e_n.alpha, e_n.beta}, rc * rc - rs * rs, 2.0f * rc * rs);
    }
    /* Fig. 4b: fundamental and negative-sequence carrier; with cfg.leak the
     * fundamental's leak taken out of the latter (fs_hfi_filter_step_nl) */
    if (h->cfg.leak != 0) { fs_hfi_filter_step_nl(&h->filt, i, e_h, e_n, &h->i_f, &h->i_hn); }
    else { fs_hfi_filter_step_cs(&h->filt, i, e_h, e_n, &h->i_f, &h->i_hn); }
    const fs_dq lp_p = h->filt.srff_p.lp, lp_n = h->filt.srff_n.lp;
    /* the negative carrier's amplitude, eq. (26)'s divisor: the second
     * SRFF's state, with cfg.leak less the fundamental's leak it also holds
     * (its image in leak_n, the same SRFF on the fundamental, the same
     * frame). The leak is a tone near w_h of w_b / w_h of the fundamental
     * (header, "Normalisation"): it can outgrow a small carrier, it does not
     * scale with the injection's gain, and the magnitude of the sum averages
     * to about the larger of the two, not to the carrier (motulator's 2.2 kW
     * IPMSM at rated load: 1.9 x the carrier, the observer at 0.53 of its
     * designed gain, the load's release 8.85 el.deg off instead of 4.1) */
    fs_dq cn = lp_n;
    if (h->cfg.leak != 0) {
        cn.d -= h->filt.leak_n.lp.d;
        cn.q -= h->filt.leak_n.lp.q;
    }
    h->i_p = sqrtf(lp_p.d * lp_p.d + lp_p.q * lp_p.q);
    h->i_n = sqrtf(cn.d * cn.d + cn.q * cn.q);
    h->i_n_avg += h->k_avg * (h->i_n - h->i_n_avg);

    /* eq. (26): the cross product of the expected carrier direction
     * e^{j(-theta_h + 2 (theta_hat + delta) + phi_ref)} with i_hn: e_n turned
     * by phi_ref (and by 2 delta with a table) */
    const fs_ab ref = fs_inv_park((fs_dq){e_n.alpha, e_n.beta}, h->rot_ref.alpha, h->rot_ref.beta);
    h->ref = ref;
    const float c = ref.alpha, s = ref.beta;
    float eps_n = 0.0f;
    const bool settling = h->k_settle > 0;
    if (settling) {
        --h->k_settle;
    } else if (h->i_n_avg > 0.0f) {
        eps_n = fs_clamp_sym((c * h->i_hn.beta - s * h->i_hn.alpha) / h->i_n_avg, 1.0f);
    } else {
        /* no negative-sequence carrier yet: no error to correct by */
    }
    h->eps = 0.5f * eps_n;   /* sin(2 dtheta) / 2 ~ dtheta */

    /* Fig. 5; with the filter's lag in the loop, nothing to take while the
     * filters settle (its image of the angle stays at the estimate) */
    if (h->cfg.lag && settling) { (void)fs_motion_obs_predict(&h->obs, T_ff); }
    else { (void)fs_motion_obs_step(&h->obs, h->eps, T_ff); }
    h->theta = h->obs.theta_hat;
    h->w = h->obs.w_hat;
    if (h->cfg.lag != 0) {   /* the speed's observer on that angle (header) */
        (void)fs_motion_obs_step(&h->obs_w, fs_wrap_pi(h->theta - h->obs_w.theta_hat), T_ff);
        h->w = h->obs_w.w_hat;
    }

    /* eq. (22), for the interval the voltage computed now acts over */
    const fs_ab e_v = fs_inv_park((fs_dq){e_h.alpha, e_h.beta}, h->rot_u.alpha, h->rot_u.beta);
    h->u.alpha = h->gain * h->u_amp * e_v.alpha;
    h->u.beta = h->gain * h->u_amp * e_v.beta;
    h->theta_h = fs_wrap_pi(theta_h + h->dtheta_h);
    /* the carrier's phasor for the next step: this one turned by w_h Ts (a
     * complex product, not a cosine and sine), formed afresh from theta_h
     * once a carrier period so that the products' rounding (an ulp or two
     * a period, on the amplitude and the angle) does not accumulate */
    if (++h->k_h >= h->n_iq) {
        h->k_h = 0;
        h->e_h.alpha = fs_cosf(h->theta_h);
        h->e_h.beta = fs_sinf(h->theta_h);
    } else {
        h->e_h.alpha = e_h.alpha * h->rot_h.alpha - e_h.beta * h->rot_h.beta;
        h->e_h.beta = e_h.beta * h->rot_h.alpha + e_h.alpha * h->rot_h.beta;
    }
    return h->theta;
}
