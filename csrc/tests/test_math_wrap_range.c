/* fs-test-sources:
 *
 * fs_math.h promises fs_wrap_pi(x) in (-pi, pi] "for any finite input".
 * Check it over all float magnitudes (a strided walk over the bit patterns of
 * both signs) and at a few inputs where the reduction x - 2pi floor((x+pi)/2pi)
 * rounds across the boundary (found by exhaustive search).
 */
#include <stdint.h>
#include <string.h>

#include "control/fs_math.h"
#include "tests/fs_test.h"

static long out_of_range = 0;

static void check(float x)
{
    float y = fs_wrap_pi(x);
    if (!(y > -FS_PI && y <= FS_PI)) {
        ++out_of_range;
        FS_CHECK(0, "wrap(%.9g) = %.9g outside (-pi, pi]", x, y);
    } else {
        FS_CHECK(1, "in range");
    }
}

int main(void)
{
    /* Rounding across +pi for moderate inputs (|x| in 1e3 .. 1e5). */
    check(1021.01764f);
    check(16389.6895f);
    check(2221.11f);
    /* Inputs whose float reduction is meaningless (|x| >= 2^24 * 2pi / 2). */
    check(1e9f);
    check(-1e30f);
    check(3e38f);
    check(-3e38f);
    for (uint32_t bits = 0; bits < 0x7f800000u; bits += 4099) {
        float x;
        memcpy(&x, &bits, sizeof x);
        check(x);
        check(-x);
    }
    if (out_of_range) fprintf(stderr, "%ld inputs wrapped outside (-pi, pi]\n", out_of_range);
    return fs_test_summary("test_math_wrap_range");
}
