#include "fs_losses.h"

#include <math.h>

static int nonneg(double x) { return x >= 0.0 && isfinite(x); }
static int pos(double x) { return x > 0.0 && isfinite(x); }
static double sgn(double x) { return (x > 0.0) - (x < 0.0); }

fs_status fs_iron_check(const fs_iron_config *c)
{
    if (!c) return FS_ERR_NULL;
    if (!nonneg(c->P_ref)) return FS_ERR_PARAM;
    if (c->P_ref == 0.0) return FS_OK;
    if (!pos(c->w_ref) || !pos(c->psi_ref) || !pos(c->w_band)) return FS_ERR_PARAM;
    if (!(c->k_hyst >= 0.0 && c->k_hyst <= 1.0)) return FS_ERR_PARAM;
    return c->beta >= 1.0 && c->beta <= 3.0 ? FS_OK : FS_ERR_PARAM;
}

/* r^beta, by multiplication at the usual exponent 2 */
static double flux_power(double r, double beta) { return beta == 2.0 ? r * r : pow(r, beta); }

double fs_iron_loss(const fs_iron_config *c, double w_e, double psi)
{
    const double f = fabs(w_e) / c->w_ref, r = psi / c->psi_ref;
    if (c->beta == 2.0)   /* the thermal model's form since it was written: the same bits */
        return c->P_ref * r * r * (c->k_hyst * f + (1.0 - c->k_hyst) * f * f);
    return c->P_ref * (c->k_hyst * f * flux_power(r, c->beta) + (1.0 - c->k_hyst) * f * f * r * r);
}

double fs_iron_torque(const fs_iron_config *c, int pole_pairs, double w_m, double psi)
{
    if (c->P_ref == 0.0) return 0.0;
    const double r = psi / c->psi_ref, p = (double)pole_pairs;
    /* P_h = P_ref k |p w_m| / w_ref r^beta: a torque of constant size p P_ref k r^beta / w_ref */
    double s = w_m / c->w_band;
    s = s > 1.0 ? 1.0 : (s < -1.0 ? -1.0 : s);
    const double T_h = p * c->P_ref * c->k_hyst * flux_power(r, c->beta) / c->w_ref * s;
    /* P_e = P_ref (1 - k) (p w_m / w_ref)^2 r^2: a viscous torque */
    const double T_e = c->P_ref * (1.0 - c->k_hyst) * r * r * p * p * w_m / (c->w_ref * c->w_ref);
    return T_h + T_e;
}

fs_status fs_device_check(const fs_device_config *c)
{
    if (!c) return FS_ERR_NULL;
    if (!c->enabled) return FS_OK;
    if (c->kind != FS_DEV_IGBT && c->kind != FS_DEV_MOSFET) return FS_ERR_PARAM;
    const double v[7] = {c->u_t, c->r_t, c->u_d, c->r_d, c->E_on, c->E_off, c->E_rr};
    for (int k = 0; k < 7; ++k)
        if (!nonneg(v[k])) return FS_ERR_PARAM;
    if (!pos(c->I_ref) || !pos(c->V_ref)) return FS_ERR_PARAM;
    const double e[4] = {c->k_i_t, c->k_v_t, c->k_i_d, c->k_v_d};
    for (int k = 0; k < 4; ++k)
        if (!(e[k] >= 0.0 && e[k] <= 3.0)) return FS_ERR_PARAM;
    return FS_OK;
}

double fs_device_drop(const fs_device_config *c, int transistor, double i)
{
    return transistor ? sgn(i) * c->u_t + c->r_t * i : sgn(i) * c->u_d + c->r_d * i;
}

int fs_device_transistor(const fs_device_config *c, int high, double i)
{
    /* upper rail: a current out of the leg (i > 0) flows through the upper
     * transistor, into it through the upper diode; the lower rail the other way */
    return c->kind == FS_DEV_MOSFET || (high ? i > 0.0 : i < 0.0);
}

double fs_device_commutation(const fs_device_config *c, int high_before, double i, double v)
{
    const double a = fabs(i) / c->I_ref, b = fabs(v) / c->V_ref;
    if (a == 0.0) return 0.0;
    /* the leaving rail's transistor carried the current: it turns off */
    if (high_before ? i > 0.0 : i < 0.0)
        return c->E_off * pow(a, c->k_i_t) * pow(b, c->k_v_t);
    /* else its diode (a MOSFET's body diode in the dead time) did: the
     * incoming transistor turns on hard and the diode recovers */
    return c->E_on * pow(a, c->k_i_t) * pow(b, c->k_v_t) + c->E_rr * pow(a, c->k_i_d) * pow(b, c->k_v_d);
}
