/* Tiny assertion helpers for the C unit tests (one test program per file).
 *
 * Each test file starts with a line
 *   fs-test-sources: control/fs_pi.c control/fs_status.c
 * inside a comment, naming the library sources (relative to csrc/) it links;
 * tests/test_c_units.py reads that line, compiles the file with ASan/UBSan and
 * runs it. A failed check prints file:line and the values, and the program
 * exits non-zero at the end (all checks run, so one run shows every failure).
 */
#ifndef FS_TEST_H
#define FS_TEST_H

#include <math.h>
#include <stdio.h>

static int fs_test_failures = 0;
static int fs_test_checks = 0;

/* Condition check with a printf-style message. */
#define FS_CHECK(cond, ...)                                                   \
    do {                                                                      \
        ++fs_test_checks;                                                     \
        if (!(cond)) {                                                        \
            ++fs_test_failures;                                               \
            if (fs_test_failures <= 50) {                                     \
                fprintf(stderr, "%s:%d: FAILED: %s: ", __FILE__, __LINE__, #cond); \
                fprintf(stderr, __VA_ARGS__);                                 \
                fputc('\n', stderr);                                          \
            }                                                                 \
        }                                                                     \
    } while (0)

/* |a - b| <= tol (NaN fails). */
#define FS_CHECK_NEAR(a, b, tol, what)                                        \
    do {                                                                      \
        double fs_a_ = (double)(a), fs_b_ = (double)(b), fs_t_ = (double)(tol); \
        FS_CHECK(fabs(fs_a_ - fs_b_) <= fs_t_, "%s: %.17g vs %.17g (diff %.3g, tol %.3g)", \
                 (what), fs_a_, fs_b_, fabs(fs_a_ - fs_b_), fs_t_);           \
    } while (0)

/* |a - b| <= rel * max(|a|, |b|) + abs_tol. */
#define FS_CHECK_REL(a, b, rel, abs_tol, what)                                \
    do {                                                                      \
        double fs_ra_ = (double)(a), fs_rb_ = (double)(b);                    \
        double fs_m_ = fabs(fs_ra_) > fabs(fs_rb_) ? fabs(fs_ra_) : fabs(fs_rb_); \
        FS_CHECK_NEAR(fs_ra_, fs_rb_, (rel) * fs_m_ + (abs_tol), what);       \
    } while (0)

#define FS_CHECK_EQ_INT(a, b, what)                                           \
    do {                                                                      \
        long fs_a_ = (long)(a), fs_b_ = (long)(b);                            \
        FS_CHECK(fs_a_ == fs_b_, "%s: %ld vs %ld", (what), fs_a_, fs_b_);     \
    } while (0)

/* Call at the end of main: prints a summary, returns the exit status. */
static inline int fs_test_summary(const char *name)
{
    if (fs_test_failures) {
        fprintf(stderr, "%s: %d of %d checks FAILED\n", name, fs_test_failures, fs_test_checks);
        return 1;
    }
    printf("%s: all %d checks passed\n", name, fs_test_checks);
    return 0;
}

#define FS_TEST_PI 3.14159265358979323846

/* An angle wrapped to (-pi, pi], in double: the tests' reference. */
static inline double fs_test_wrap(double x)
{
    const double two_pi = 2.0 * FS_TEST_PI;
    x = fmod(x, two_pi);
    if (x > FS_TEST_PI) x -= two_pi;
    if (x <= -FS_TEST_PI) x += two_pi;
    return x;
}

#endif /* FS_TEST_H */
