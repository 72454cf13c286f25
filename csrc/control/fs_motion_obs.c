#include "fs_motion_obs.h"
#include "fs_math.h"

/* The gains with the error read through the filter (header): the triple
 * pole (c = 1 - z_o) and the filter's own, once or twice; g = 1 - E, m3 the
 * disturbance's predictor gain (the same as without). */
static FS_COLD void lag_gains(fs_motion_obs *obs, float c, float g, float m3)
{
    const float Ts = obs->cfg.Ts, f1 = obs->f1, f2 = obs->f2;
    const float b = -expm1f(-obs->w_lag * Ts), a = 1.0f - b, h = 1.0f - 0.5f * b;
    const float c2 = c * c, c3 = c2 * c;
    float m1, m2, m4, m5 = 0.0f;
    if (obs->lag == 1) {
        m1 = (3.0f * c2 - 0.5f * c3 + b * (3.0f * c - g - 1.5f * c2 + 0.25f * c3) - g * (3.0f * c - g))
             / (b * (1.0f - 0.5f * g));
        m4 = (3.0f * c - g - 0.5f * b * m1) / h;
        m2 = (c3 + 3.0f * b * c2 - b * g * m1 - b * (0.5f * Ts * f1 + f2) * m3) / (b * f1);
        obs->c_theta = 0.5f * b;
        obs->c_f1 = h;
    } else {
        const float P = c3 * g - 4.0f * c3 + 12.0f * c2 - 12.0f * c * g + 4.0f * g * g;
        const float Q = c3 * g - 3.0f * c3 - 3.0f * c2 * g + 12.0f * c2 - 12.0f * c + 4.0f * g;
        const float k = (2.0f - g) * (2.0f - g), cg = c - g;
        m1 = (4.0f * cg * cg * cg + 2.0f * b * P - b * b * Q) / (b * b * k);
        m4 = (P - b * Q) / (b * k);
        m5 = (2.0f - b) * P / (2.0f * b * k);
        m2 = (3.0f * b * c2 + 2.0f * c3 - b * g * m1 - b * (Ts * f1 + f2) * m3) / (b * f1);
        obs->c_theta = 0.25f * b * b;
        obs->c_f1 = h * (1.0f + 0.5f * b);
        obs->c_f2 = -h;
    }
    obs->l_a = m3;
    obs->l_w = (m2 - f1 * m3) / obs->E;
    obs->l_theta = m1 - f1 * obs->l_w - f2 * obs->l_a;
    obs->l_f1 = (m4 - b * obs->l_theta) / a;
    obs->l_f2 = (m5 - b * h * (obs->l_theta - obs->l_f1)) / a;
    obs->a_lag = a;
}

FS_COLD fs_status fs_motion_obs_init(fs_motion_obs *obs, const fs_motion_obs_config *cfg)
{
    return fs_motion_obs_init_lag(obs, cfg, 0, 0.0f);
}

FS_COLD fs_status fs_motion_obs_init_lag(fs_motion_obs *obs, const fs_motion_obs_config *cfg, int lag, float w_lag)
{
    if (!obs || !cfg) { return FS_ERR_NULL; }
    if (!(cfg->Ts > 0.0f) || !isfinite(cfg->Ts)) { return FS_ERR_TS; }
    if (!(cfg->J > 0.0f) || !isfinite(cfg->J)) { return FS_ERR_J; }
    if (!(cfg->B >= 0.0f) || !isfinite(cfg->B)) { return FS_ERR_PARAM; }
    if (cfg->pole_pairs < 1) { return FS_ERR_POLE_PAIRS; }
    if (!(cfg->bandwidth > 0.0f) || !(cfg->bandwidth * cfg->Ts <= 0.5f)) { return FS_ERR_BANDWIDTH; }
    if (lag < 0 || lag > 2) { return FS_ERR_PARAM; }
    if (lag > 0 && (!(w_lag > 0.0f) || !(w_lag * cfg->Ts <= 0.5f))) { return FS_ERR_BANDWIDTH; }
    obs->cfg = *cfg;
    obs->lag = lag;
    obs->w_lag = lag > 0 ? w_lag : 0.0f;
    const float Ts = cfg->Ts, J = cfg->J, B = cfg->B, w_o = cfg->bandwidth;
    const float p = (float)cfg->pole_pairs;
    obs->k_u = p / J;

    /* Sampled model of J dw/dt = T - B w (zero-order hold), x = B Ts / J:
     * g = 1 - E = 1 - exp(-x), f1 = Ts g / x, f2 = Ts^2 (x - g) / x^2,
     * by series where x - g cancels. */
    const float x = B * Ts / J;
    const float g = -expm1f(-x);
    float phi1, phi2;
    if (x < 0.1f) {
        phi1 = 1.0f - x * (0.5f - x * (1.0f / 6.0f - x * (1.0f / 24.0f - x * (1.0f / 120.0f))));
        phi2 = 0.5f - x * (1.0f / 6.0f - x * (1.0f / 24.0f - x * (1.0f / 120.0f - x * (1.0f / 720.0f))));
    } else {
        phi1 = g / x;
        phi2 = (1.0f - phi1) / x;
    }
    obs->E = 1.0f - g;
    obs->f1 = Ts * phi1;
    obs->f2 = Ts * Ts * phi2;

    /* Fig. 5 observer: triple pole of the error at z_o = exp(-w_o Ts)
     * (header: predictor gain m, then the filter gain l = Phi^-1 m). */
    const float c = -expm1f(-w_o * Ts);
    obs->z_o = 1.0f - c;
    const float f1 = obs->f1, f2 = obs->f2;
    const float m1 = 3.0f * c - g;
    const float m3 = c * c * c / (f1 * Ts);
    const float m2 = (3.0f * c * c - g * m1 - f2 * m3) / f1;
    obs->l_a = m3;
    obs->l_w = (m2 - f1 * m3) / obs->E;
    obs->l_theta = m1 - f1 * obs->l_w - f2 * obs->l_a;
    obs->a_lag = 1.0f;
    obs->c_theta = obs->c_f1 = obs->c_f2 = obs->l_f1 = obs->l_f2 = 0.0f;
    if (lag > 0) { lag_gains(obs, c, g, m3); }
    obs->l_T = obs->l_a / obs->k_u;

    /* continuous-time equivalents, on the electrical error (divided by p) */
    const float K_d_m = 3.0f * J * w_o - B;
    obs->K_d = K_d_m / p;
    obs->K_p = (3.0f * J * w_o * w_o - B * K_d_m / J) / p;
    obs->K_i = J * w_o * w_o * w_o / p;

    fs_motion_obs_reset(obs, 0.0f, 0.0f);
    /* gains beyond the float range: p / J, 1 / Ts^2 or 1 / E = exp(B Ts / J) too large */
    return fs_fin(obs->k_u) && fs_fin(obs->l_theta + obs->l_w + obs->l_a + obs->l_T) ? FS_OK : FS_ERR_PARAM;
}

void fs_motion_obs_reset(fs_motion_obs *obs, float theta, float w)
{
    obs->theta_hat = fs_wrap_pi(theta);
    obs->w_hat = w;
    obs->T_d_hat = 0.0f;
    obs->r1 = obs->r2 = 0.0f;
}

float fs_motion_obs_step(fs_motion_obs *obs, float eps, float T_ff)
{
    /* predict over the period that ended now, with the torque that acted in it */
    const float acc = obs->k_u * (T_ff + obs->T_d_hat);
    const float d_theta = obs->f1 * obs->w_hat + obs->f2 * acc;
    const float w_pred = obs->E * obs->w_hat + obs->f1 * acc;
    /* innovation: eps is against the previous theta_hat, the prediction moved on
     * (through the filter: against the filter's images, header) */
    float innov;
    if (obs->lag > 0) {
        const float a = obs->a_lag, b = 1.0f - a;
        innov = fs_wrap_pi(eps - obs->c_theta * d_theta + obs->c_f1 * obs->r1 + obs->c_f2 * obs->r2);
        const float moved = d_theta + obs->l_theta * innov, r1 = obs->r1 - obs->l_f1 * innov;
        obs->r2 = a * (obs->r2 - obs->l_f2 * innov) - b * (1.0f - 0.5f * b) * (moved + r1);
        obs->r1 = a * r1 - b * moved;
    } else {
        innov = fs_wrap_pi(eps - d_theta);
    }
    /* correct: the PID of Fig. 5 in sampled form */
    obs->theta_hat = fs_wrap_pi(obs->theta_hat + d_theta + obs->l_theta * innov);
    obs->w_hat = w_pred + obs->l_w * innov;
    obs->T_d_hat += obs->l_T * innov;
    return obs->theta_hat;
}

float fs_motion_obs_predict(fs_motion_obs *obs, float T_ff)
{
    const float acc = obs->k_u * (T_ff + obs->T_d_hat);
    obs->theta_hat = fs_wrap_pi(obs->theta_hat + obs->f1 * obs->w_hat + obs->f2 * acc);
    obs->w_hat = obs->E * obs->w_hat + obs->f1 * acc;
    obs->r1 = obs->r2 = 0.0f;
    return obs->theta_hat;
}
