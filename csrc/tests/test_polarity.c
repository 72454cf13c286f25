/* fs-test-sources: control/fs_polarity.c control/fs_status.c
 *
 * fs_polarity, the magnet polarity detection by two d-current pulses (LOCK,
 * +i_pulse, -i_pulse, DONE), against the header's sequence call by call:
 * n_lock = round(t_lock / Ts), n_pulse = round(t_pulse / Ts) (both rounding
 * directions tried); calls 1 .. n_lock - 1 return 0, call n_lock starts the
 * + pulse (a return acts over the period after its call), returned n_pulse
 * times, then -i_pulse n_pulse times, then 0 for ever, the stage DONE from
 * the call that returns that first 0. Each stage thus takes n samples, and
 * those of a pulse stage follow periods under that pulse. Without LOCK
 * (t_lock = 0) the first + sample precedes any + reference: + is returned
 * n_pulse - 1 times (harmless, only the second half is averaged).
 * Averaging: of a stage's n_pulse samples only k >= n_pulse / 2 count
 * (n_pulse - n_pulse / 2 of them, odd and even n_pulse tried). The first
 * half is fed 1000 A above the rest, which moves any average it leaks into
 * by > 38 A; the second half a ramp base + k / 2, whose mean moves by
 * >= 0.25 A if its first sample is dropped. Float sums of halves are exact:
 * averages checked to 1e-5 A.
 * Decision: flip = I_p(+) < I_p(-) (the + pulse opposed the magnet: the
 * estimate points at the south pole), both ways and on equality (no flip);
 * samples after DONE (fed 1e6) change nothing. Reset, init refusals.
 */
#include "control/fs_polarity.h"
#include "tests/fs_test.h"

/* i_p fed at sample k (0-based) of a pulse stage of n samples: junk in the
 * first half, base + k/2 in the second. */
static float feed(int k, int n, float base)
{
    return k < n / 2 ? base + 1000.0f : base + 0.5f * (float)(k - n / 2);
}

/* The mean of the second half of feed(), in double. */
static double second_half_mean(int n, float base)
{
    double sum = 0.0;
    for (int k = n / 2; k < n; ++k) sum += feed(k, n, base);
    return sum / (n - n / 2);
}

/* One whole sequence from reset, checking every reference and stage; base_pos
 * and base_neg set the two averages. Call c (1-based) carries sample
 * j = c - 1 - n_lock of the pulses and returns the reference for the period
 * after it; m = c - n_lock counts from the call that starts the + pulse. */
static void sequence(fs_polarity *p, float base_pos, float base_neg)
{
    const int n_lock = p->n_lock, n = p->n_pulse;
    const float i_pulse = p->cfg.i_pulse;
    int errors = 0, n_plus = 0, n_minus = 0;
    for (int c = 1; c <= n_lock + 2 * n + 20; ++c) {
        const int j = c - 1 - n_lock, m = c - n_lock;
        float i_p = 7.0f;                                            /* LOCK */
        if (j >= 0 && j < n) i_p = feed(j, n, base_pos);
        else if (j >= n && j < 2 * n) i_p = feed(j - n, n, base_neg);
        else if (j >= 2 * n) i_p = 1e6f;                             /* DONE: changes nothing */
        const float ref = fs_polarity_step(p, i_p);
        n_plus += ref == i_pulse;
        n_minus += ref == -i_pulse;
        const float want = m < 0 ? 0.0f : m < n ? i_pulse : m < 2 * n ? -i_pulse : 0.0f;
        const int stage = m < 0 ? FS_POLARITY_LOCK : m < n ? FS_POLARITY_POS : m < 2 * n ? FS_POLARITY_NEG
                                                                                 : FS_POLARITY_DONE;
        if ((ref != want || p->stage != stage) && ++errors <= 5)
            FS_CHECK(0, "call %d: reference %g (want %g), stage %d (want %d)", c, ref, want, p->stage, stage);
    }
    FS_CHECK_EQ_INT(errors, 0, "calls with a wrong reference or stage");
    /* n_lock = 0: the first sample precedes any + reference (see the report) */
    FS_CHECK_EQ_INT(n_plus, n_lock > 0 ? n : n - 1, "periods with +i_pulse");
    FS_CHECK_EQ_INT(n_minus, n, "periods with -i_pulse");
    const double e_pos = second_half_mean(n, base_pos), e_neg = second_half_mean(n, base_neg);
    FS_CHECK_NEAR(p->i_p_pos, e_pos, 1e-5, "I_p average over the second half of the + pulse");
    FS_CHECK_NEAR(p->i_p_neg, e_neg, 1e-5, "I_p average over the second half of the - pulse");
    FS_CHECK(p->flip == (e_pos < e_neg), "flip %d with I_p(+) %g, I_p(-) %g", p->flip, e_pos, e_neg);
}

int main(void)
{
    fs_polarity p;
    /* n_lock: 0.01236 / 1e-4 = 123.6 -> 124; n_pulse: 0.00506 / 1e-4 = 50.6 -> 51 (odd: 26 averaged) */
    fs_polarity_config c = {1e-4f, 4.0f, 0.01236f, 0.00506f};
    FS_CHECK_EQ_INT(fs_polarity_init(&p, &c), FS_OK, "init");
    FS_CHECK_EQ_INT(p.n_lock, 124, "n_lock = round(t_lock / Ts)");
    FS_CHECK_EQ_INT(p.n_pulse, 51, "n_pulse = round(t_pulse / Ts)");
    FS_CHECK(p.stage == FS_POLARITY_LOCK && p.k == 0 && !p.flip, "init resets");

    /* + pulse 10 .. 22.5 A, - pulse 11 ..: I_p(+) < I_p(-): flip */
    sequence(&p, 10.0f, 11.0f);
    FS_CHECK(p.flip, "I_p(+) < I_p(-) must flip");
    /* reset, and the other way: no flip */
    fs_polarity_reset(&p);
    FS_CHECK(p.stage == FS_POLARITY_LOCK && p.k == 0 && !p.flip && p.sum_pos == 0.0f && p.sum_neg == 0.0f &&
             p.i_p_pos == 0.0f && p.i_p_neg == 0.0f, "reset clears");
    sequence(&p, 11.0f, 10.0f);
    FS_CHECK(!p.flip, "I_p(+) > I_p(-) must not flip");
    fs_polarity_reset(&p);
    sequence(&p, 10.0f, 10.0f);
    FS_CHECK(!p.flip, "equal I_p: no flip");

    /* even n_pulse (40.3 -> 40: 20 averaged), one LOCK step */
    c.t_lock = 1e-4f;
    c.t_pulse = 4.03e-3f;
    FS_CHECK_EQ_INT(fs_polarity_init(&p, &c), FS_OK, "init");
    FS_CHECK(p.n_lock == 1 && p.n_pulse == 40, "n_lock %d, n_pulse %d", p.n_lock, p.n_pulse);
    sequence(&p, 3.0f, 2.5f);
    FS_CHECK(!p.flip, "no flip");
    /* no LOCK: starts in the + pulse (the header's sequence without t_lock) */
    c.t_lock = 0.0f;
    c.t_pulse = 4.0f * c.Ts;
    FS_CHECK_EQ_INT(fs_polarity_init(&p, &c), FS_OK, "t_lock = 0, t_pulse = 4 Ts");
    FS_CHECK(p.n_lock == 0 && p.n_pulse == 4 && p.stage == FS_POLARITY_POS, "no LOCK stage");
    sequence(&p, 2.0f, 5.0f);
    FS_CHECK(p.flip, "flip");

    /* refusals */
    c = (fs_polarity_config){1e-4f, 4.0f, 0.01f, 0.005f};
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
    return fs_test_summary("test_polarity");
}
