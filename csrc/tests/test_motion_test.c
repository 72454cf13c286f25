/* fs-test-sources: control/fs_motion_test.c control/fs_transforms.c control/fs_status.c
 *
 * fs_motion_test, the magnet polarity by a bounded motion, against its
 * header call by call: n = round(t / Ts) for the lock, each half of the
 * doublet and the settling; the lock's calls return 0, its last the
 * doublet's first sample; the doublet is i sin(pi (k + 1/2) / n_push) for
 * k = 0 .. 2 n_push - 1, then n_settle zeros, then the reading. A toy
 * rotor (J dw/dt = s k_T i_q, s = +1 on a right estimate, -1 on a pi-off
 * one) and an estimate that is the rotor's angle (plus pi when off) plus a
 * bias of 30 el.deg per A of q current (the estimate moving with the
 * current by itself, larger than the turn and against it): decided both
 * ways, the turn the rotor's own; a held rotor refused after the retries
 * (1.5 x up to i_push_max); a noisy estimate raises the threshold to twice
 * its spread and, beyond theta_max, is refused after FS_MOTION_LOCKS locks;
 * a rotor turning on its own is refused before the doublet and after it;
 * reset; the config's refusals.
 */
#include "control/fs_motion_test.h"
#include "tests/fs_test.h"

#include <math.h>

#define TS 1e-4f
#define PI_F 3.14159265f
#define PI_D 3.14159265358979323846

typedef struct {
    double theta, w;      /* the rotor, el. rad and rad/s */
    double s;             /* +1: the estimate on the north pole, -1: pi off */
    double k;             /* el. rad/s^2 per A of q current: p k_T / J */
    double drift;         /* el. rad/s the rotor turns at on its own */
    double bias;          /* el. rad of estimate per A of q current */
    double noise;         /* +- el. rad of estimate, alternating */
    int n;
} rotor;

/* One period under the q current i: the rotor moves (constant acceleration
 * over the period), the estimate is read at its end. */
static float step(fs_motion_test *m, rotor *r, float *i)
{
    const double a = r->s * r->k * (double)*i;
    r->theta += r->w * TS + 0.5 * a * TS * TS + r->drift * TS;
    r->w += a * TS;
    const double est = r->theta + (r->s < 0 ? PI_D : 0.0) + r->bias * (double)*i + ((r->n++ & 1) ? r->noise : -r->noise);
    *i = fs_motion_test_step(m, (float)remainder(est, 2.0 * PI_D));
    return *i;
}

/* Runs until DONE or UNDETERMINED (or a step limit); returns the steps. */
static int run(fs_motion_test *m, rotor *r)
{
    float i = 0.0f;
    int k = 0;
    while (m->stage != FS_MOTION_DONE && m->stage != FS_MOTION_UNDETERMINED && k < 200000) {
        step(m, r, &i);
        ++k;
    }
    return k;
}

int main(void)
{
    fs_motion_test m;
    /* n_lock 0.0100 / 1e-4 = 100, n_push 0.0050 / 1e-4 = 50, n_settle 0.0030 / 1e-4 = 30 */
    fs_motion_test_config c = {TS, 2.0f, 0.0f, 0.0100f, 0.0050f, 0.0030f, 0.07f, 0.0f};
    FS_CHECK_EQ_INT(fs_motion_test_init(&m, &c), FS_OK, "init");
    FS_CHECK(m.n_lock == 100 && m.n_push == 50 && m.n_settle == 30, "n_lock %d n_push %d n_settle %d", m.n_lock, m.n_push,
             m.n_settle);
    FS_CHECK(m.cfg.i_push_max == 2.0f && fabsf(m.cfg.theta_max - 0.28f) < 1e-6f, "defaults: no retry, theta_max 4 theta_dec");
    FS_CHECK(m.stage == FS_MOTION_LOCK && m.threshold == 0.07f, "reset");

    /* the sequence's shape on a held rotor (k = 0): the lock, the doublet, the settling, then a larger one */
    {
        rotor r = {0.3, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0};
        c.i_push_max = 3.0f;
        fs_motion_test_init(&m, &c);
        float i = 0.0f;
        int errors = 0;
        for (int k = 1; k < 100; ++k)
            if (step(&m, &r, &i) != 0.0f && ++errors <= 3) FS_CHECK(0, "lock call %d returned %g", k, i);
        double sum = 0.0;
        for (int k = 0; k < 100; ++k) {   /* the lock's last call returns the doublet's first sample */
            const float want = 2.0f * sinf(PI_F * ((float)k + 0.5f) / 50.0f);
            const float got = step(&m, &r, &i);
            sum += got;
            if (fabsf(got - want) > 1e-5f && ++errors <= 3) FS_CHECK(0, "doublet sample %d: %g, want %g", k, got, want);
        }
        FS_CHECK(m.stage == FS_MOTION_PUSH && step(&m, &r, &i) == 0.0f && m.stage == FS_MOTION_SETTLE,
                 "the settling after 2 n_push samples");
        FS_CHECK_NEAR(sum, 0.0, 1e-4, "the doublet's mean current");
        for (int k = 1; k < 30; ++k)
            if (step(&m, &r, &i) != 0.0f && ++errors <= 3) FS_CHECK(0, "settling call %d returned %g", k, i);
        step(&m, &r, &i);
        FS_CHECK(m.stage == FS_MOTION_PUSH && m.attempts == 1 && m.i_now == 3.0f, "no turn: a doublet 1.5 x larger (capped)");
        FS_CHECK_NEAR(i, 3.0f * sinf(PI_F * 0.5f / 50.0f), 1e-6, "its first sample");
        FS_CHECK_EQ_INT(errors, 0, "calls with a wrong current");
        run(&m, &r);
        FS_CHECK(m.stage == FS_MOTION_UNDETERMINED && m.attempts == 2 && !m.moved, "held: undetermined at i_push_max");
        FS_CHECK(fs_motion_test_step(&m, 0.0f) == 0.0f, "0 once ended");
    }

    /* decided both ways, through a bias of 30 el.deg/A that turns the estimate against the rotor while the current flows */
    for (int pole = 0; pole < 2; ++pole) {
        c.i_push_max = 0.0f;
        fs_motion_test_init(&m, &c);
        rotor r = {-1.0, 0.0, pole ? -1.0 : 1.0, 4000.0, 0.0, 0.5236, 0.0, 0};
        run(&m, &r);
        /* the doublet's exact turn: the sampled sine's double sum, the current held over each period */
        double w = 0.0, th = 0.0;
        for (int k = 0; k < 100; ++k) {
            const double a = 4000.0 * 2.0 * sin(PI_D * (k + 0.5) / 50.0);
            th += w * TS + 0.5 * a * TS * TS;
            w += a * TS;
        }
        FS_CHECK(m.stage == FS_MOTION_DONE && m.flip == (pole == 1), "pole %d: flip %d", pole, m.flip);
        FS_CHECK_NEAR(fabs(m.turn), th, 1e-4, "the turn read is the rotor's (no bias at zero current)");
        FS_CHECK_NEAR(th, 4000.0 * 2.0 * pow(0.01, 2.0) / (2.0 * PI_D), 2e-3 * th, "a T t^2 / (2 pi) for the sine over t");
        FS_CHECK_NEAR(r.w, 0.0, 1e-6, "the rotor at rest after the doublet");
        FS_CHECK(m.attempts == 1 && !m.moved, "one doublet");
    }

    /* noise: +-0.05 rad in the lock's second half raises the threshold to twice its spread (0.2 rad), which the
     * doublet's turn (0.127 rad at 2 A) does not reach; the retry at 3 A does */
    {
        c.i_push_max = 3.0f;
        fs_motion_test_init(&m, &c);
        rotor r = {0.0, 0.0, 1.0, 4000.0, 0.0, 0.0, 0.05, 0};
        run(&m, &r);
        FS_CHECK_NEAR(m.threshold, 0.2, 1e-5, "threshold = 2 x the spread");
        FS_CHECK(m.stage == FS_MOTION_DONE && !m.flip && m.attempts == 2, "decided on the second doublet (%d)", m.attempts);
        /* a spread beyond theta_max / 2: FS_MOTION_LOCKS locks, then refused without a doublet */
        fs_motion_test_reset(&m);
        rotor q = {0.0, 0.0, 1.0, 4000.0, 0.0, 0.0, 0.15, 0};
        const int steps = run(&m, &q);
        FS_CHECK(m.stage == FS_MOTION_UNDETERMINED && m.attempts == 0 && m.locks == FS_MOTION_LOCKS && !m.moved,
                 "too noisy: refused after the locks");
        FS_CHECK_EQ_INT(steps, FS_MOTION_LOCKS * 100, "three locks' steps");
        FS_CHECK_NEAR(q.theta, 0.0, 1e-12, "no current, no turn");
    }

    /* a rotor turning on its own (10 el. rad/s: 0.13 rad over the doublet and its settling, more than the 0.07
     * threshold): refused before any doublet */
    {
        fs_motion_test_init(&m, &c);
        rotor r = {0.0, 0.0, 1.0, 4000.0, 10.0, 0.0, 0.0, 0};
        run(&m, &r);
        FS_CHECK(m.stage == FS_MOTION_UNDETERMINED && m.moved && m.attempts == 0, "turning: refused before the doublet");
        /* one that starts turning after the lock (a load arriving): the settlings find it turning, refused once its
         * turn passes theta_max */
        fs_motion_test_init(&m, &c);
        rotor q = {0.0, 0.0, -1.0, 4000.0, 0.0, 0.0, 0.0, 0};
        float i = 0.0f;
        for (int k = 0; k < 100; ++k) step(&m, &q, &i);
        q.drift = 100.0;   /* 0.15 rad over the settling's second half */
        run(&m, &q);
        FS_CHECK(m.stage == FS_MOTION_UNDETERMINED && m.moved && fabsf(m.turn) > m.cfg.theta_max, "a load turns it: refused (turn %g)",
                 m.turn);
    }

    /* refusals, one field off at a time */
#define REFUSED(field, value, status) \
    do { fs_motion_test_config b_ = c; b_.field = (value); FS_CHECK_EQ_INT(fs_motion_test_init(&m, &b_), status, #field); } while (0)
    FS_CHECK_EQ_INT(fs_motion_test_init(NULL, &c), FS_ERR_NULL, "NULL");
    REFUSED(Ts, 0.0f, FS_ERR_TS);
    REFUSED(i_push, -1.0f, FS_ERR_I_MAX);
    REFUSED(i_push_max, 1.0f, FS_ERR_I_MAX);   /* below i_push */
    REFUSED(t_lock, 7e-4f, FS_ERR_PARAM);      /* below 8 Ts */
    REFUSED(t_settle, 0.0f, FS_ERR_PARAM);     /* below Ts */
    REFUSED(theta_dec, 1.6f, FS_ERR_PARAM);    /* beyond pi/2 */
    REFUSED(theta_max, 0.05f, FS_ERR_PARAM);   /* below theta_dec */
    REFUSED(t_push, NAN, FS_ERR_PARAM);
    return fs_test_summary("test_motion_test");
}
