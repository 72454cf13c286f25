/* Host side of the PIL harness: the simulator (csrc/sim/fs_sim.c, compiled
 * unchanged but with -Dfs_drive_step=pil_hook_step) calls this in place of
 * the drive step. It records each step's input and output, and, with the
 * loop closed through the emulator, sends the input to the target and takes
 * the target's output instead of stepping the host's drive. A test harness:
 * globals are fine here, never in csrc/control. */
#include <string.h>
#include <unistd.h>
#include "control/fs_drive.h"
#include "control/fs_math.h"

static fs_drive_in *rec_in;
static fs_drive_out *rec_out;
static long rec_cap, rec_n;
static int to_target = -1, from_target = -1, remote_err;

void pil_record(fs_drive_in *in, fs_drive_out *out, long cap)
{
    rec_in = in, rec_out = out, rec_cap = cap, rec_n = 0;
}

long pil_recorded(void) { return rec_n; }

void pil_remote(int fd_to, int fd_from)
{
    to_target = fd_to, from_target = fd_from, remote_err = 0;
}

int pil_remote_error(void) { return remote_err; }

static int xfer(int fd, void *buf, size_t n, int writing)
{
    char *p = buf;
    while (n > 0) {
        ssize_t r = writing ? write(fd, p, n) : read(fd, p, n);
        if (r <= 0) return -1;
        p += r, n -= (size_t)r;
    }
    return 0;
}

void pil_hook_step(fs_drive *drv, const fs_drive_in *in, fs_drive_out *out)
{
    if (to_target >= 0) {
        if (remote_err || xfer(to_target, (void *)in, sizeof *in, 1) || xfer(from_target, out, sizeof *out, 0)) {
            remote_err = 1;   /* the target is gone: hold the duties at 0.5, the run reports it */
            memset(out, 0, sizeof *out);
            for (int k = 0; k < FS_PHASES_MAX; ++k) out->duty[k] = 0.5f;
        }
    } else {
        fs_drive_step(drv, in, out);
    }
    if (rec_in && rec_n < rec_cap) {
        rec_in[rec_n] = *in;
        rec_out[rec_n] = *out;
        ++rec_n;
    }
}

/* The library's trigonometry on the host, for the libm probe (fs_cis
 * returns a complex float, which cffi cannot take from a call): per (x, y)
 * pair, cos x, sin x and atan2(y, x). */
void pil_trig(const float *xy, float *out, long n)
{
    for (long k = 0; k < n; ++k) {
        out[3 * k] = fs_cosf(xy[2 * k]);
        out[3 * k + 1] = fs_sinf(xy[2 * k]);
        out[3 * k + 2] = fs_atan2f(xy[2 * k + 1], xy[2 * k]);
    }
}
