/* A QEMU TCG plugin (API version 1, QEMU 4.2 to 8.x): counts the guest's
 * executed instructions and, each time the instruction at address `mark`
 * executes, appends the count so far (uint64) to the file `out`.
 *   -plugin insn_count.so,mark=0x1234,out=counts.bin[,hist=hist.bin]
 * With hist, it also counts executions per halfword address of the first
 * HIST_BYTES of the address space (the image's code) and writes them there
 * at exit: a flat profile.
 * The declarations are the few the plugin uses, as QEMU's qemu-plugin.h
 * documents them (Debian's qemu-system-arm ships no header). */
#include <fcntl.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef uint64_t qemu_plugin_id_t;
typedef struct {
    const char *target_name;
    struct { int min, cur; } version;
    bool system_emulation;
    union { struct { int smp_vcpus, max_vcpus; } system; };
} qemu_info_t;
struct qemu_plugin_tb;
struct qemu_plugin_insn;
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS };
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
typedef void (*trans_cb)(qemu_plugin_id_t, struct qemu_plugin_tb *);
typedef void (*vcpu_udata_cb)(unsigned int, void *);
typedef void (*udata_cb)(qemu_plugin_id_t, void *);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, trans_cb cb);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *tb, size_t idx);
uint64_t qemu_plugin_insn_vaddr(const struct qemu_plugin_insn *insn);
void qemu_plugin_register_vcpu_insn_exec_inline(struct qemu_plugin_insn *insn, enum qemu_plugin_op op,
                                                void *ptr, uint64_t imm);
void qemu_plugin_register_vcpu_insn_exec_cb(struct qemu_plugin_insn *insn, vcpu_udata_cb cb,
                                            enum qemu_plugin_cb_flags flags, void *userdata);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, udata_cb cb, void *userdata);

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

#define HIST_BYTES (1u << 20)
static uint64_t count, mark;
static uint64_t *hist;
static const char *hist_path;
static int fd = -1;
static uint64_t buf[4096];
static size_t nbuf;

static void flush(void)
{
    if (nbuf && fd >= 0 && write(fd, buf, nbuf * sizeof buf[0]) < 0) fd = -1;
    nbuf = 0;
}

static void on_mark(unsigned int vcpu, void *u)
{
    (void)vcpu, (void)u;
    buf[nbuf++] = count;
    if (nbuf == sizeof buf / sizeof buf[0]) flush();
}

static void on_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    (void)id;
    for (size_t k = 0, n = qemu_plugin_tb_n_insns(tb); k < n; ++k) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, k);
        if (qemu_plugin_insn_vaddr(insn) == mark)
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_mark, QEMU_PLUGIN_CB_NO_REGS, NULL);
        qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, &count, 1);
        uint64_t a = qemu_plugin_insn_vaddr(insn);
        if (hist && a < HIST_BYTES)
            qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, &hist[a >> 1], 1);
    }
}

static void at_exit(qemu_plugin_id_t id, void *u)
{
    (void)id, (void)u;
    flush();
    if (fd >= 0) close(fd);
    int h = hist ? open(hist_path, O_WRONLY | O_CREAT | O_TRUNC, 0644) : -1;
    if (h >= 0) {
        if (write(h, hist, HIST_BYTES / 2 * sizeof *hist) < 0) {
        }
        close(h);
    }
}

__attribute__((visibility("default")))
int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv)
{
    (void)info;
    const char *out = NULL;
    for (int k = 0; k < argc; ++k) {
        if (!strncmp(argv[k], "mark=", 5)) mark = strtoull(argv[k] + 5, NULL, 0);
        else if (!strncmp(argv[k], "out=", 4)) out = argv[k] + 4;
        else if (!strncmp(argv[k], "hist=", 5)) hist_path = argv[k] + 5;
    }
    if (!mark || !out || (fd = open(out, O_WRONLY | O_CREAT | O_TRUNC, 0644)) < 0) return 1;
    if (hist_path && !(hist = calloc(HIST_BYTES / 2, sizeof *hist))) return 1;
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_trans);
    qemu_plugin_register_atexit_cb(id, at_exit, NULL);
    return 0;
}
