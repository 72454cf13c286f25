/* The float libm functions the drive calls (and the trigonometry it calls
 * instead of libm's, fs_cis and fs_atan2f), on the target: reads n argument pairs (x, y)
 * from probe_in.bin, writes each function's result per pair to
 * probe_out.bin, for bench/pil.py to hold against the host's. */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "fs_math.h"

int sh_call(int op, void *arg);

#define N_FUN 15
static float xy[2 * 1024], res[N_FUN * 1024];

static int sh_open(const char *name, int mode)
{
    uint32_t a[3] = {(uint32_t)(uintptr_t)name, (uint32_t)mode, (uint32_t)strlen(name)};
    return sh_call(0x01, a);
}

static uint32_t sh_io(int op, int fd, void *buf, uint32_t len)
{
    uint32_t a[3] = {(uint32_t)fd, (uint32_t)(uintptr_t)buf, len};
    return len - (uint32_t)sh_call(op, a);
}

int main(void)
{
    int fi = sh_open("probe_in.bin", 1), fo = sh_open("probe_out.bin", 5);
    if (fi < 0 || fo < 0) return 1;
    uint32_t got;
    while ((got = sh_io(0x06, fi, xy, sizeof xy) / (2 * sizeof(float))) > 0) {
        for (uint32_t k = 0; k < got; ++k) {
            const float x = xy[2 * k], y = xy[2 * k + 1];
            float *r = &res[N_FUN * k];
            r[0] = sinf(x), r[1] = cosf(x), r[2] = atan2f(y, x), r[3] = expf(y), r[4] = expm1f(y);
            r[5] = logf(fabsf(x) + 1e-3f), r[6] = sqrtf(fabsf(x)), r[7] = tanhf(y), r[8] = atanf(x);
            r[9] = fmodf(x, 6.2831853f), r[10] = tanf(0.4f * x), r[11] = x * y + y;
            r[12] = fs_cosf(x), r[13] = fs_sinf(x), r[14] = fs_atan2f(y, x);
        }
        if (sh_io(0x05, fo, res, got * N_FUN * sizeof(float)) != got * N_FUN * sizeof(float)) return 1;
        if (got < 1024) break;
    }
    return 0;
}
