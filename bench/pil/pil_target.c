/* Processor in the loop: fs_drive_step on the (emulated) Cortex-M4F.
 *
 * Reads, over semihosting, a header, the fs_drive_config and then one
 * fs_drive_in per step from the input file; writes a header (the init's
 * status, the target's struct sizes, the stack the steps used) and one
 * fs_drive_out per step to the output file. The input is a regular file (a
 * recorded replay, read in blocks) or a FIFO (the loop closed through the
 * host's plant: one sample per exchange). Around each step it calls
 * pil_mark(), whose address the instruction-counting plugin watches.
 * Layouts: pil_layout.h (generated) static-asserts the host's offsets.
 */
#include <stdint.h>
#include <string.h>
#include "fs_drive.h"
#include "pil_layout.h"

int sh_call(int op, void *arg);

#define PIL_MAGIC 0x4C495046u   /* "FPIL" */
#define BLOCK 64
#define STACK_PAINT 16384       /* bytes painted below the step's caller */

typedef struct {
    uint32_t magic, n_steps, block, size_cfg, size_in, size_out;
} pil_header_in;

typedef struct {
    uint32_t magic;
    int32_t status;
    uint32_t size_drive, size_cfg, size_in, size_out;
    uint32_t stack_used;        /* bytes: the deepest the steps went below their caller's frame */
    uint32_t steps;
} pil_header_out;

static fs_drive drive;
static fs_drive_config cfg;
static fs_drive_in ins[BLOCK];
static fs_drive_out outs[BLOCK];

__attribute__((noinline)) void pil_mark(void) { __asm__ volatile("" ::: "memory"); }

static int sh_open(const char *name, int mode)
{
    uint32_t a[3] = {(uint32_t)(uintptr_t)name, (uint32_t)mode, (uint32_t)strlen(name)};
    return sh_call(0x01, a);
}

/* bytes read (SYS_READ returns the count not read) */
static uint32_t sh_read(int fd, void *buf, uint32_t len)
{
    uint32_t a[3] = {(uint32_t)fd, (uint32_t)(uintptr_t)buf, len};
    return len - (uint32_t)sh_call(0x06, a);
}

static int sh_write(int fd, const void *buf, uint32_t len)
{
    uint32_t a[3] = {(uint32_t)fd, (uint32_t)(uintptr_t)buf, len};
    return sh_call(0x05, a) == 0;
}

static void say(const char *s) { sh_call(0x04, (void *)s); }

/* Paint the stack below the caller's frame; measure how deep it was used. */
__attribute__((noinline)) static uint32_t *stack_paint(void)
{
    uintptr_t sp;
    __asm__ volatile("mov %0, sp" : "=r"(sp));
    volatile uint32_t *top = (volatile uint32_t *)(sp - 256);   /* clear of this function's own frame */
    for (volatile uint32_t *p = top - STACK_PAINT / 4; p < top; ++p) *p = 0xA5C3E1F7u;
    return (uint32_t *)top;
}

static uint32_t stack_used(const uint32_t *top)
{
    const volatile uint32_t *p = top - STACK_PAINT / 4;
    while (p < top && *p == 0xA5C3E1F7u) ++p;
    return (uint32_t)((const char *)top - (const char *)p);
}

int main(void)
{
    int fi = sh_open("pil_in.bin", 1), fo = sh_open("pil_out.bin", 5);   /* rb, wb */
    if (fi < 0 || fo < 0) {
        say("pil: cannot open pil_in.bin / pil_out.bin\n");
        return 1;
    }
    pil_header_in h;
    if (sh_read(fi, &h, sizeof h) != sizeof h || h.magic != PIL_MAGIC || h.size_cfg != sizeof cfg
        || h.size_in != sizeof(fs_drive_in) || h.size_out != sizeof(fs_drive_out) || h.block < 1 || h.block > BLOCK) {
        say("pil: bad header or struct sizes differ from the host's\n");
        return 1;
    }
    if (sh_read(fi, &cfg, sizeof cfg) != sizeof cfg) return 1;
    pil_header_out ho = {PIL_MAGIC, (int32_t)fs_drive_init(&drive, &cfg), sizeof(fs_drive), sizeof cfg,
                         sizeof(fs_drive_in), sizeof(fs_drive_out), 0, 0};
    pil_mark();   /* two marks back to back: the counting's own overhead */
    pil_mark();
    uint32_t *top = stack_paint();
    uint32_t steps = 0;
    while (ho.status == FS_OK && steps < h.n_steps) {
        uint32_t want = h.n_steps - steps < h.block ? h.n_steps - steps : h.block;
        uint32_t got = sh_read(fi, ins, want * sizeof ins[0]) / sizeof ins[0];
        for (uint32_t k = 0; k < got; ++k) {
            pil_mark();
            fs_drive_step(&drive, &ins[k], &outs[k]);
            pil_mark();
        }
        if (got && !sh_write(fo, outs, got * sizeof outs[0])) return 1;
        steps += got;
        if (got < want) break;   /* end of the input: the host closed it */
    }
    ho.stack_used = stack_used(top);
    ho.steps = steps;
    /* the header last, at the end of the output (a FIFO cannot seek back) */
    return sh_write(fo, &ho, sizeof ho) ? 0 : 1;
}
