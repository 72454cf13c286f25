/* The machine and its integration that test_hfi.c and test_hfi_amplitude.c
 * share (test_hfi.c's header says how): R = 0.036 ohm, L_d = 65 uH, L_q =
 * 90 uH, Ts = 1e-4 s, u_h = 5 V, w_h = 2 pi 1 kHz. Included after fs_hfi.h,
 * fs_math.h and fs_test.h; its functions static inline, so that a test
 * that leaves one unused builds under -Werror. */
#ifndef FS_TEST_HFI_PLANT_H
#define FS_TEST_HFI_PLANT_H

#define TS 1e-4
#define W_H (2.0 * FS_TEST_PI * 1000.0)
#define U_H 5.0
#define R_S 0.036
#define SL (0.5 * (65e-6 + 90e-6))
#define DL (0.5 * (65e-6 - 90e-6))
#define X_H (0.5 * W_H * TS)
#define SINC (sin(X_H) / X_H)
#define DEG (FS_TEST_PI / 180.0)
#define N_RUN 3000
#define N_AVG 500

static inline fs_hfi_config config(void)
{
    fs_hfi_config c;
    memset(&c, 0, sizeof c);
    c.Ts = (float)TS; c.delay = 1.0f; c.u_h = (float)U_H; c.w_h = (float)W_H;
    c.R_s = (float)R_S; c.L_d = 65e-6f; c.L_q = 90e-6f;
    c.obs.J = 1.87e-3f; c.obs.pole_pairs = 5;
    return c;
}

/* One SRFF (fs_srff.h) on a tone v away from its frame, exactly. */
static inline double complex srff(double v, double w_b)
{
    double a = exp(-w_b * TS);
    double complex zi = cexp(-I * v * TS);
    return 0.5 * (1.0 + a) * (1.0 - zi) / (1.0 - a * zi);
}

/* Continuous injection u_h e^{j w_h t} at rotor speed w_r (rotor-frame phasors:
 * the positive sequence sees w_h, the negative w_h - 2 w_r): the phase of the
 * negative carrier after H_p against e^{j(2 theta - w_h t)}, and |I_p|, |I_n|. */
static inline double carrier(double w_r, double w_b_p, double *Ip_abs, double *In_abs)
{
    const double w2 = W_H - 2.0 * w_r;
    double complex Ip = U_H / ((R_S + I * W_H * SL) + W_H * w2 * DL * DL / (R_S + I * w2 * SL));
    double complex In = I * w2 * DL * conj(Ip) / (R_S - I * w2 * SL);
    if (Ip_abs) *Ip_abs = cabs(Ip);
    if (In_abs) *In_abs = cabs(In);
    return carg(In * srff(-2.0 * (W_H - w_r), w_b_p));
}

typedef struct {
    double R, theta0, w_r, d_ax;  /* machine: rotor at theta0 + w_r t */
    double complex i_dc;          /* a fundamental current held by the voltage R i_dc */
    int delay;                    /* periods from computing a voltage to applying it */
    double th_start, expect;      /* estimator reset angle; expected theta_hat - theta */
    int k_flip;                   /* step at which fs_hfi_set_angle adds pi (0: never) */
} scen;

typedef struct {
    double mean, max, w, i_p, i_n;   /* error mean and max, means of h.w, h.i_p, h.i_n */
    int k_first_eps;                 /* first step with a nonzero error used */
    fs_hfi h;
} result;

static inline double complex current(const scen *s, double complex psi, double t)
{
    double complex e2 = cexp(2.0 * I * (s->theta0 + s->w_r * t + s->d_ax));
    return (SL * psi - DL * e2 * conj(psi)) / (SL * SL - DL * DL);
}

static inline double complex dpsi(const scen *s, double complex psi, double t, double complex u)
{ return u + s->R * (s->i_dc - current(s, psi, t)); }

/* The flux over one sampling period from t under the held voltage u: 20
 * classical Runge-Kutta steps (the tests' plant between two samples) */
static inline double complex plant_period(const scen *s, double complex psi, double t, double complex u)
{
    const double dt = TS / 20.0;
    for (int m = 0; m < 20; ++m, t += dt) {
        double complex k1 = dpsi(s, psi, t, u);
        double complex k2 = dpsi(s, psi + 0.5 * dt * k1, t + 0.5 * dt, u);
        double complex k3 = dpsi(s, psi + 0.5 * dt * k2, t + 0.5 * dt, u);
        double complex k4 = dpsi(s, psi + dt * k3, t + dt, u);
        psi += dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
    return psi;
}

static inline void run(const char *what, const scen *s, const fs_hfi_config *cfg, result *r)
{
    fs_hfi *h = &r->h;
    FS_CHECK_EQ_INT(fs_hfi_init(h, cfg), FS_OK, "init");
    fs_hfi_reset(h, (float)fs_test_wrap(s->th_start), 0.0f);
    /* the current i_dc, and no DC flux left by the start of the carrier */
    double complex psi = SL * s->i_dc + DL * cexp(2.0 * I * (s->theta0 + s->d_ax)) * conj(s->i_dc)
                       + U_H / (I * W_H * SINC * SINC) * cexp(I * W_H * s->delay * TS);
    double complex u_hist[3] = {0.0, 0.0, 0.0};
    double expect = s->expect;
    r->mean = r->max = r->w = r->i_p = r->i_n = 0.0; r->k_first_eps = -1;
    for (int k = 0; k < N_RUN; ++k) {
        double t = k * TS;
        double complex i = current(s, psi, t);
        fs_ab ia = {(float)creal(i), (float)cimag(i)};
        fs_hfi_step(h, ia, 0.0f);
        if (r->k_first_eps < 0 && h->eps != 0.0f) r->k_first_eps = k;
        if (s->k_flip > 0 && k == s->k_flip) {   /* keeps the filters and the carrier */
            const fs_hfi_filter f = h->filt;
            const float theta_h = h->theta_h;
            fs_hfi_set_angle(h, fs_wrap_pi(h->theta + FS_PI), h->w);
            FS_CHECK(h->theta_h == theta_h && !memcmp(&f, &h->filt, sizeof f), "set_angle moved carrier or filters");
            expect += FS_TEST_PI;
        }
        u_hist[k % 3] = h->u.alpha + I * h->u.beta;
        double complex u = k >= s->delay ? u_hist[(k - s->delay) % 3] : 0.0;
        if (k >= N_RUN - N_AVG) {
            double e = fs_test_wrap(h->theta - (s->theta0 + s->w_r * t) - expect);
            r->mean += e / N_AVG;
            r->max = fmax(r->max, fabs(e));
            r->w += h->w / N_AVG; r->i_p += h->i_p / N_AVG; r->i_n += h->i_n / N_AVG;
        }
        psi = plant_period(s, psi, t, u);
    }
    printf("%-40s expected %+9.4f deg: residual mean %+.4f max %.4f deg; w %+.3f rad/s\n", what,
           s->expect / DEG, r->mean / DEG, r->max / DEG, r->w);
}

#endif /* FS_TEST_HFI_PLANT_H */
