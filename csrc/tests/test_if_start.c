/* fs-test-sources: control/fs_if_start.c control/fs_transforms.c control/fs_status.c
 *
 * fs_if_start, the I/f frame with its damping, against its header:
 *  - without damping the reference is (i_start, 0); the frame accelerates at
 *    a_start towards the target, held within +-w_handover, the angle the sum
 *    of Ts w; the wait at w_handover counts and times out after t_handover
 *    (never with t_handover 0);
 *  - with damping, the stator's voltage and current made as a rotor with
 *    EMF w_r psi_f (sin delta, cos delta) in the frame (through R and L)
 *    would make them: a rotor in step (w_r = w, whatever the load angle)
 *    leaves no damping current once the filters have settled, where taking
 *    the frame's EMF off along q only would leave w psi_f sin(delta) / r
 *    while the frame accelerates; a rotor faster than the frame gets a
 *    current against its EMF's excess, -(w_r - w) psi_f (sin, cos) / r_damp
 *    to within the band-pass's gain, and the high-pass forgets a steady one;
 *  - the magnitude held within i_max; reset; the config's refusals.
 */
#include "control/fs_if_start.h"
#include "control/fs_math.h"
#include "tests/fs_test.h"

#include <math.h>

#define TS 1e-4f

/* The voltage over the period that ended and the current now, in the
 * stationary frame, as a machine without saliency makes them: the current
 * (i_d, i_q) in the frame at s's angle now, the one before held from the
 * last call, u = R (i_k + i_k-1) / 2 + L (i_k - i_k-1) / Ts + e, the rotor's
 * EMF e = (e_d, e_q) given in the frame at the period's middle. */
static fs_ab i_last;
static bool have_last;

static void feed(const fs_if_start *s, fs_dq i, fs_dq e, float R, float L, fs_ab *i_ab, fs_ab *u_ab)
{
    const float th_m = s->theta - 0.5f * TS * s->w;
    *i_ab = fs_inv_park(i, fs_cosf(s->theta), fs_sinf(s->theta));
    if (!have_last) i_last = *i_ab;
    const fs_ab em = fs_inv_park(e, fs_cosf(th_m), fs_sinf(th_m));
    u_ab->alpha = 0.5f * R * (i_ab->alpha + i_last.alpha) + L * (i_ab->alpha - i_last.alpha) / TS + em.alpha;
    u_ab->beta = 0.5f * R * (i_ab->beta + i_last.beta) + L * (i_ab->beta - i_last.beta) / TS + em.beta;
    i_last = *i_ab;
    have_last = true;
}

int main(void)
{
    fs_if_start s;
    /* no damping */
    fs_if_start_config c = {TS, 10.0f, 5000.0f, 200.0f, 0.1f, 1e-3f, 0.05f, 0.0f, 0.0f, 20.0f, 0.01f};
    FS_CHECK_EQ_INT(fs_if_start_init(&s, &c), FS_OK, "init");
    FS_CHECK(s.theta == 0.0f && s.w == 0.0f && !s.timed_out, "reset");
    fs_ab z = {0.0f, 0.0f};
    double th = 0.0;
    int errors = 0;
    for (int k = 0; k < 400; ++k) {   /* 0.04 s at 5000 rad/s^2 reaches 200 at 0.04 s */
        const fs_dq i = fs_if_start_step(&s, 1000.0f, z, z);
        if ((i.d != 10.0f || i.q != 0.0f) && ++errors <= 3) FS_CHECK(0, "step %d: (%g, %g)", k, i.d, i.q);
        th += (double)TS * fmin(5000.0 * TS * (k + 1), 200.0);
    }
    FS_CHECK_EQ_INT(errors, 0, "steps with another reference");
    FS_CHECK_NEAR(s.w, 200.0, 1e-3, "the frame at w_handover, not the target");
    FS_CHECK_NEAR(s.theta, remainder(th, 2.0 * 3.14159265358979), 2e-3, "the angle sums Ts w");
    FS_CHECK(!s.timed_out && s.t_held < 1e-3f, "just arrived");
    for (int k = 0; k < 120; ++k) fs_if_start_step(&s, 1000.0f, z, z);
    FS_CHECK(s.timed_out && s.t_held > 0.01f, "timed out after t_handover at w_handover (held %g s)", s.t_held);
    fs_if_start_reset(&s, 1.0f, -50.0f);
    FS_CHECK(s.theta == 1.0f && s.w == -50.0f && !s.timed_out && s.t_held == 0.0f, "reset to a frame");
    for (int k = 0; k < 10; ++k) fs_if_start_step(&s, -1000.0f, z, z);
    FS_CHECK_NEAR(s.w, -55.0, 1e-3, "accelerates towards a negative target at a_start");
    c.t_handover = 0.0f;
    fs_if_start_init(&s, &c);
    for (int k = 0; k < 3000; ++k) fs_if_start_step(&s, 1000.0f, z, z);
    FS_CHECK(!s.timed_out, "t_handover 0: no limit");

    /* damping: r_damp 0.05 ohm about w_swing 100 rad/s (high-pass at 25, low-pass at 400 rad/s) */
    const float psi = 0.05f, R = 0.1f, L = 1e-3f, r_d = 0.05f;
    c.r_damp = r_d;
    c.w_swing = 100.0f;
    c.t_handover = 0.0f;
    c.w_handover = 400.0f;
    FS_CHECK_EQ_INT(fs_if_start_init(&s, &c), FS_OK, "init with damping");
    have_last = false;
    /* in step at 40 el.deg of load angle while the frame accelerates (to 400 rad/s in 0.08 s): nothing left */
    const float delta = 0.6981317f;
    fs_dq i = {10.0f, 0.0f};
    fs_ab i_ab, u_ab;
    float worst = 0.0f;
    for (int k = 0; k < 1600; ++k) {
        const fs_dq e = {s.w * psi * sinf(delta), s.w * psi * cosf(delta)};
        feed(&s, i, e, R, L, &i_ab, &u_ab);
        i = fs_if_start_step(&s, 1000.0f, i_ab, u_ab);
        if (k > 400) worst = fmaxf(worst, hypotf(i.d - 10.0f, i.q));
    }
    FS_CHECK(worst < 0.05f, "in step, whatever the load angle: no damping current (%g A)", worst);
    /* the same with the frame's EMF taken off along q alone would leave (a psi sin delta / w_hp) / r_d on d */
    FS_CHECK(5000.0f * psi * sinf(delta) / 25.0f / r_d > 100.0f * 0.05f, "which would be large");

    /* a rotor 20 rad/s faster than the frame at 200 rad/s, delta 0: the current opposes the excess EMF (1 V on q) */
    fs_if_start_init(&s, &c);
    fs_if_start_reset(&s, 0.0f, 200.0f);
    have_last = false;
    i = (fs_dq){10.0f, 0.0f};
    for (int k = 0; k < 2000; ++k) {   /* settle in step first */
        const fs_dq e = {0.0f, s.w * psi};
        feed(&s, i, e, R, L, &i_ab, &u_ab);
        i = fs_if_start_step(&s, 200.0f, i_ab, u_ab);
    }
    FS_CHECK(fabsf(i.q) < 0.05f && fabsf(i.d - 10.0f) < 0.05f, "in step: (%g, %g)", i.d, i.q);
    float peak_q = 0.0f, peak_d = 0.0f;
    for (int k = 0; k < 100; ++k) {   /* 10 ms: the low-pass (2.5 ms) has risen, the high-pass (40 ms) barely fallen */
        const fs_dq e = {0.0f, (s.w + 20.0f) * psi};
        feed(&s, i, e, R, L, &i_ab, &u_ab);
        i = fs_if_start_step(&s, 200.0f, i_ab, u_ab);
        peak_q = fminf(peak_q, i.q);
        peak_d = fmaxf(peak_d, fabsf(i.d - 10.0f));
    }
    FS_CHECK(peak_q < -0.6f * 20.0f * psi / r_d && peak_q > -1.0f * 20.0f * psi / r_d,
             "the damping current against the EMF's excess: %g A (20 psi / r_d = %g)", peak_q, 20.0f * psi / r_d);
    FS_CHECK(peak_d < 0.05f, "along the EMF (q here): d %g", peak_d);
    for (int k = 0; k < 4000; ++k) {   /* held faster for 0.4 s: the high-pass forgets it */
        const fs_dq e = {0.0f, (s.w + 20.0f) * psi};
        feed(&s, i, e, R, L, &i_ab, &u_ab);
        i = fs_if_start_step(&s, 200.0f, i_ab, u_ab);
    }
    FS_CHECK(fabsf(i.q) < 0.01f * 20.0f * psi / r_d, "a steady excess forgotten: %g A", i.q);

    /* the magnitude held within i_max: a 100 V excess asks 2000 A */
    fs_if_start_init(&s, &c);
    fs_if_start_reset(&s, 0.0f, 200.0f);
    have_last = false;
    i = (fs_dq){10.0f, 0.0f};
    for (int k = 0; k < 50; ++k) {
        const fs_dq e = {0.0f, s.w * psi + 100.0f};
        feed(&s, i, e, R, L, &i_ab, &u_ab);
        i = fs_if_start_step(&s, 200.0f, i_ab, u_ab);
    }
    FS_CHECK_NEAR(hypotf(i.d, i.q), 20.0, 1e-4, "|i| at i_max");

    /* refusals, one field off at a time */
#define REFUSED(field, value, status) \
    do { fs_if_start_config b_ = c; b_.field = (value); FS_CHECK_EQ_INT(fs_if_start_init(&s, &b_), status, #field); } while (0)
    FS_CHECK_EQ_INT(fs_if_start_init(NULL, &c), FS_ERR_NULL, "NULL");
    REFUSED(Ts, -1.0f, FS_ERR_TS);
    REFUSED(i_start, 0.0f, FS_ERR_I_MAX);
    REFUSED(a_start, 0.0f, FS_ERR_PARAM);
    REFUSED(L, 0.0f, FS_ERR_LD);
    REFUSED(w_swing, 0.0f, FS_ERR_BANDWIDTH);      /* with damping */
    REFUSED(w_swing, 2000.0f, FS_ERR_BANDWIDTH);   /* w_swing Ts above 0.1 */
    REFUSED(i_max, 5.0f, FS_ERR_I_MAX);            /* below i_start */
    REFUSED(r_damp, NAN, FS_ERR_PARAM);
    return fs_test_summary("test_if_start");
}
