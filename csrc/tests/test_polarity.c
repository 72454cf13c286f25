/* fs-test-sources: control/fs_polarity.c control/fs_status.c
 *
 * fs_polarity, the magnet polarity detection by pairs of d-current pulses
 * (LOCK, +i, -i, then DONE, another pair 1.5 times larger, or UNDETERMINED),
 * against the header call by call: n_lock = round(t_lock / Ts), n_pulse =
 * round(t_pulse / Ts); calls 1 .. n_lock - 1 return 0, call n_lock starts
 * the + pulse, returned n_pulse times, then - n_pulse times, then 0 (or the
 * next pair). Averaging: only the last n_avg samples of a pulse count, n_avg
 * the second half rounded down to whole carrier periods; the samples before
 * are fed 1000 A above, which moves any average they leak into by far more
 * than the 1e-4 A the checks allow. The window's samples alternate
 * base +- a, so the average is base (even n_avg) and the spread a.
 * Decision: D = (I+ - I-) / mean against max(d_min, 3 sigma_D), sigma_D =
 * sqrt((var+ + var-) / n_eff) / mean, the variances those of the carrier
 * periods' means (a ripple within each period is not noise): decided both ways, refused on equal
 * averages (after the retries, each 1.5x larger up to i_pulse_max) and on
 * a difference drowned in the spread; n_eff from w_filter; a half pulse whose
 * mean estimated speed is more than w_max (default w_filter / 10) from the
 * half before: undetermined at once (a steady 100 el. rad/s with +-50 of noise
 * in every other case: a rotor held turning is measured). Reset, refusals.
 */
#include "control/fs_polarity.h"
#include "tests/fs_test.h"

#include <math.h>

/* i_p at sample k (0-based) of a pulse of n samples whose last n_avg count. */
static float feed(int k, int n, int n_avg, float base, float a)
{
    if (k < n - n_avg) return base + 1000.0f;
    return base + ((k & 1) ? a : -a);
}

/* The estimated speed during a pair: 100 el. rad/s (a rotor held turning)
 * +- 50 of noise in the + pulse, 100 + spin +- 50 in the - pulse. */
static float spin;
static float w_at(int j, int n) { return 100.0f + (j >= n ? spin : 0.0f) + ((j & 1) ? 50.0f : -50.0f); }

/* One pair of pulses from its first call (the + pulse's reference already
 * returned by the previous call); returns the reference of the last call. */
static float pair(fs_polarity *p, float base_pos, float base_neg, float a, int *errors)
{
    const int n = p->n_pulse;
    const float i = p->i_now;
    float ref = 0.0f;
    for (int j = 0; j < 2 * n; ++j) {
        const bool pos = j < n;
        ref = fs_polarity_step(p, feed(pos ? j : j - n, n, p->n_avg, pos ? base_pos : base_neg, a), w_at(j, n));
        const float want = j < n - 1 ? i : -i;
        if (j < 2 * n - 1 && ref != want && ++*errors <= 5) FS_CHECK(0, "sample %d: reference %g, want %g", j, ref, want);
    }
    return ref;
}

/* LOCK, then pairs until the detector ends; returns the pairs run. */
static int sequence(fs_polarity *p, float base_pos, float base_neg, float a)
{
    int errors = 0, pairs = 0;
    for (int c = 1; c < p->n_lock; ++c)
        if (fs_polarity_step(p, 7.0f, 1.0f) != 0.0f && ++errors <= 5) FS_CHECK(0, "LOCK call %d returned current", c);
    if (p->n_lock > 0) FS_CHECK(fs_polarity_step(p, 7.0f, 1.0f) == p->cfg.i_pulse, "LOCK's last call starts the + pulse");
    float ref;
    do {
        const float i = p->i_now;
        ref = pair(p, base_pos, base_neg, a, &errors);
        ++pairs;
        if (p->stage == FS_POLARITY_POS) FS_CHECK(ref == p->i_now && p->i_now == fminf(1.5f * i, p->cfg.i_pulse_max),
                                                  "a retry starts 1.5 x larger: %g after %g", p->i_now, i);
    } while (p->stage == FS_POLARITY_POS && pairs < 20);
    FS_CHECK(ref == 0.0f, "0 once ended");
    FS_CHECK(fs_polarity_step(p, 1e6f, 3.0f) == 0.0f, "and after");
    FS_CHECK_EQ_INT(errors, 0, "calls with a wrong reference");
    FS_CHECK_EQ_INT(p->attempts, pairs, "attempts");
    return pairs;
}

int main(void)
{
    fs_polarity p;
    /* n_lock: 0.01236 / 1e-4 = 123.6 -> 124; n_pulse: 0.00506 / 1e-4 = 50.6 -> 51, second half 26 */
    fs_polarity_config c = {1e-4f, 4.0f, 0.01236f, 0.00506f, 0.0f, 0.0f, 0.0f, 0, 0.0f};
    FS_CHECK_EQ_INT(fs_polarity_init(&p, &c), FS_OK, "init");
    FS_CHECK(p.n_lock == 124 && p.n_pulse == 51 && p.n_avg == 26, "n_lock %d, n_pulse %d, n_avg %d", p.n_lock, p.n_pulse, p.n_avg);
    FS_CHECK(p.stage == FS_POLARITY_LOCK && !p.flip && p.cfg.i_pulse_max == 4.0f && p.cfg.d_min == FS_POLARITY_D_MIN,
             "init resets; defaults: no retry, d_min %g", p.cfg.d_min);

    /* I+ 10 A, I- 11 A: D = -1/10.5 = -9.5 %, 1.9 x d_min: decided, flip */
    FS_CHECK_EQ_INT(sequence(&p, 10.0f, 11.0f, 0.01f), 1, "one pair");
    FS_CHECK(p.stage == FS_POLARITY_DONE && p.flip, "I+ < I- flips");
    FS_CHECK_NEAR(p.i_p_pos, 10.0, 1e-4, "I+ average over the window only");
    FS_CHECK_NEAR(p.i_p_neg, 11.0, 1e-4, "I- average over the window only");
    FS_CHECK_NEAR(p.d, -1.0 / 10.5, 1e-5, "D");
    FS_CHECK_NEAR(p.margin, (1.0 / 10.5) / FS_POLARITY_D_MIN, 1e-3, "margin = |D| / d_min");
    fs_polarity_reset(&p);
    FS_CHECK(p.stage == FS_POLARITY_LOCK && p.attempts == 0 && p.margin == 0.0f && !p.flip, "reset clears");
    sequence(&p, 11.0f, 10.0f, 0.01f);
    FS_CHECK(p.stage == FS_POLARITY_DONE && !p.flip, "I+ > I-: no flip");

    /* equal averages, retries 4 -> 6 -> 9 -> 10 A, then UNDETERMINED */
    c.i_pulse_max = 10.0f;
    FS_CHECK_EQ_INT(fs_polarity_init(&p, &c), FS_OK, "init with retries");
    FS_CHECK_EQ_INT(sequence(&p, 10.0f, 10.0f, 0.01f), 4, "pairs at 4, 6, 9 and 10 A");
    FS_CHECK(p.stage == FS_POLARITY_UNDETERMINED && p.margin < 1.0f && p.i_now == 10.0f, "undetermined at i_pulse_max");
    /* a 4.9 % difference is below d_min: refused too */
    fs_polarity_reset(&p);
    sequence(&p, 10.25f, 9.76f, 0.01f);
    FS_CHECK(p.stage == FS_POLARITY_UNDETERMINED, "|D| %g below d_min", p.d);

    /* the same 9.5 % drowned in a +-2 A spread: sigma_D = sqrt(8 / 26) / 10.5 = 5.3 %, 3 sigma 15.8 % */
    c.i_pulse_max = 0.0f;
    FS_CHECK_EQ_INT(fs_polarity_init(&p, &c), FS_OK, "init");
    sequence(&p, 10.0f, 11.0f, 2.0f);
    FS_CHECK(p.stage == FS_POLARITY_UNDETERMINED, "noise: undetermined (margin %g)", p.margin);
    FS_CHECK_NEAR(p.margin, (1.0 / 10.5) / (3.0 * sqrt(8.0 / 26.0) / 10.5), 2e-3, "margin against 3 sigma_D");
    /* a spread of +-0.7 A: 3 sigma_D = 5.5 %, above d_min; decided */
    fs_polarity_reset(&p);
    sequence(&p, 10.0f, 11.0f, 0.7f);
    FS_CHECK_NEAR(p.margin, (1.0 / 10.5) / (3.0 * sqrt(0.98 / 26.0) / 10.5), 2e-3, "margin against 3 sigma_D");
    FS_CHECK(p.stage == FS_POLARITY_DONE && p.flip, "decided");
    /* correlated samples: w_filter Ts n / 2 = 1000 * 1e-4 * 26 / 2 = 1.3 independent ones: sigma_D 4.5 x larger */
    c.w_filter = 1000.0f;
    FS_CHECK_EQ_INT(fs_polarity_init(&p, &c), FS_OK, "init");
    sequence(&p, 10.0f, 11.0f, 0.7f);
    FS_CHECK_NEAR(p.margin, (1.0 / 10.5) / (3.0 * sqrt(0.98 / 1.3) / 10.5), 2e-3, "margin with n_eff = 1.3");
    FS_CHECK(p.stage == FS_POLARITY_UNDETERMINED, "undetermined with few independent samples");

    /* the window in whole carrier periods: second half 26 -> 3 periods of 8 = 24 */
    c.w_filter = 0.0f;
    c.n_carrier = 8;
    FS_CHECK_EQ_INT(fs_polarity_init(&p, &c), FS_OK, "init");
    FS_CHECK_EQ_INT(p.n_avg, 24, "n_avg in whole carrier periods");
    sequence(&p, 3.0f, 2.5f, 0.01f);
    FS_CHECK(p.stage == FS_POLARITY_DONE && !p.flip, "decided over the rounded window");
    FS_CHECK_NEAR(p.i_p_pos, 3.0, 1e-4, "I+ over the rounded window");
    /* a +-2 A ripple that repeats every carrier period leaves the periods' means equal: decided on d_min */
    c.n_carrier = 2;
    FS_CHECK_EQ_INT(fs_polarity_init(&p, &c), FS_OK, "init");
    FS_CHECK(p.n_avg == 26 && p.n_per == 2, "n_avg %d, n_per %d", p.n_avg, p.n_per);
    sequence(&p, 10.0f, 11.0f, 2.0f);
    FS_CHECK(p.stage == FS_POLARITY_DONE && p.flip, "the carrier's ripple is not noise");
    FS_CHECK_NEAR(p.margin, (1.0 / 10.5) / FS_POLARITY_D_MIN, 1e-3, "margin = |D| / d_min");
    /* no LOCK: starts in the + pulse */
    c.t_lock = 0.0f;
    c.n_carrier = 0;
    FS_CHECK_EQ_INT(fs_polarity_init(&p, &c), FS_OK, "t_lock = 0");
    FS_CHECK(p.n_lock == 0 && p.stage == FS_POLARITY_POS, "no LOCK stage");

    /* the - pulse's speed 25 el. rad/s above the + pulse's (and +-50 of noise on every sample): decided;
     * 38: spun, undetermined without retry. 50-sample pulses, 25 a half: the noise leaves -2, +2, -2, +2 in
     * the halves' means, so the largest change is spin - 4 (21 and 34 against w_max = w_filter / 10 = 30) */
    c = (fs_polarity_config){1e-4f, 4.0f, 0.01f, 0.005f, 8.0f, 0.0f, 300.0f, 0, 0.0f};
    FS_CHECK_EQ_INT(fs_polarity_init(&p, &c), FS_OK, "init");
    FS_CHECK_NEAR(p.cfg.w_max, 30.0, 1e-5, "w_max's default: w_filter / 10");
    spin = 25.0f;
    sequence(&p, 10.0f, 11.0f, 0.01f);
    FS_CHECK(p.stage == FS_POLARITY_DONE && !p.moved && fabsf(p.w_peak - 21.0f) < 1e-3f, "25 rad/s: decided (peak %g)", p.w_peak);
    fs_polarity_reset(&p);
    spin = 38.0f;
    FS_CHECK_EQ_INT(sequence(&p, 10.0f, 11.0f, 0.01f), 1, "no retry once spun");
    FS_CHECK(p.stage == FS_POLARITY_UNDETERMINED && p.moved && p.margin == 0.0f && fabsf(p.w_peak - 34.0f) < 1e-3f,
             "38 rad/s: spun (peak %g)", p.w_peak);
    spin = 0.0f;

    /* refusals */
    c = (fs_polarity_config){1e-4f, 4.0f, 0.01f, 0.005f, 0.0f, 0.0f, 0.0f, 0, 0.0f};
    FS_CHECK_EQ_INT(fs_polarity_init(NULL, &c), FS_ERR_NULL, "NULL");
    FS_CHECK_EQ_INT(fs_polarity_init(&p, NULL), FS_ERR_NULL, "NULL config");
#define REFUSE(field, value, status) \
    do { fs_polarity_config b = c; b.field = (value); FS_CHECK_EQ_INT(fs_polarity_init(&p, &b), status, #field " = " #value); } while (0)
    REFUSE(Ts, 0.0f, FS_ERR_TS); REFUSE(Ts, -1e-4f, FS_ERR_TS); REFUSE(Ts, NAN, FS_ERR_TS); REFUSE(Ts, INFINITY, FS_ERR_TS);
    REFUSE(i_pulse, 0.0f, FS_ERR_I_MAX); REFUSE(i_pulse, -4.0f, FS_ERR_I_MAX);
    REFUSE(i_pulse, NAN, FS_ERR_I_MAX); REFUSE(i_pulse, INFINITY, FS_ERR_I_MAX);
    REFUSE(t_lock, -1e-3f, FS_ERR_PARAM); REFUSE(t_lock, NAN, FS_ERR_PARAM); REFUSE(t_lock, INFINITY, FS_ERR_PARAM);
    REFUSE(t_lock, 0.0f, FS_OK);
    REFUSE(t_pulse, 3.9e-4f, FS_ERR_PARAM); REFUSE(t_pulse, NAN, FS_ERR_PARAM); REFUSE(t_pulse, 2e3f, FS_ERR_PARAM);
    REFUSE(i_pulse_max, 3.9f, FS_ERR_I_MAX); REFUSE(i_pulse_max, NAN, FS_ERR_I_MAX); REFUSE(i_pulse_max, INFINITY, FS_ERR_I_MAX);
    REFUSE(i_pulse_max, 4.0f, FS_OK);
    REFUSE(d_min, -0.01f, FS_ERR_PARAM); REFUSE(d_min, 1.0f, FS_ERR_PARAM); REFUSE(d_min, NAN, FS_ERR_PARAM);
    REFUSE(w_filter, -1.0f, FS_ERR_BANDWIDTH); REFUSE(w_filter, INFINITY, FS_ERR_BANDWIDTH);
    REFUSE(n_carrier, -1, FS_ERR_PARAM);
    REFUSE(w_max, -0.1f, FS_ERR_PARAM); REFUSE(w_max, NAN, FS_ERR_PARAM);
    return fs_test_summary("test_polarity");
}
