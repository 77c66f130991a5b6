/* icount.c -- a minimal QEMU TCG plugin that counts executed guest instructions exactly.
 *
 * Each time the instruction at address `mark=0x...` (the firmware's `fw_mark`) is about to run,
 * it prints "PLUGIN_MARK <instructions so far>", and "PLUGIN_TOTAL <n>" at exit (both need
 * `-d plugin`). Differences between consecutive marks are the instructions a span executed.
 *
 * Plugin API v2 (QEMU >= 9.0; used with Debian bookworm-backports' 10.0). Debian ships neither
 * qemu-plugin.h nor the contrib plugins, so the few declarations needed are written out here.
 * Adapted from the project's Cortex-M recipe (shared/cortex-m/recipe.sh).
 * Build: gcc -shared -fPIC -O2 -o libicount.so icount.c */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef uint64_t qemu_plugin_id_t;
struct qemu_plugin_tb;
struct qemu_plugin_insn;
struct qemu_plugin_scoreboard;
typedef struct qemu_info_t qemu_info_t;
typedef struct { struct qemu_plugin_scoreboard *score; size_t offset; } qemu_plugin_u64;
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS, QEMU_PLUGIN_CB_R_REGS, QEMU_PLUGIN_CB_RW_REGS };
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t, void (*)(qemu_plugin_id_t, struct qemu_plugin_tb *));
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *);
struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *, size_t);
uint64_t qemu_plugin_insn_vaddr(const struct qemu_plugin_insn *);
struct qemu_plugin_scoreboard *qemu_plugin_scoreboard_new(size_t);
void qemu_plugin_register_vcpu_insn_exec_inline_per_vcpu(struct qemu_plugin_insn *, enum qemu_plugin_op, qemu_plugin_u64, uint64_t);
uint64_t qemu_plugin_u64_sum(qemu_plugin_u64);
void qemu_plugin_register_vcpu_insn_exec_cb(struct qemu_plugin_insn *, void (*)(unsigned int, void *), enum qemu_plugin_cb_flags, void *);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t, void (*)(qemu_plugin_id_t, void *), void *);
void qemu_plugin_outs(const char *);
__attribute__((visibility("default"))) int qemu_plugin_version = 2;

static qemu_plugin_u64 count;
static uint64_t mark = ~0ull;

static void say(const char *what) {
    char line[80];
    snprintf(line, sizeof line, "%s %llu\n", what, (unsigned long long)qemu_plugin_u64_sum(count));
    qemu_plugin_outs(line);
}

static void on_mark(unsigned int vcpu, void *user) { (void)vcpu; (void)user; say("PLUGIN_MARK"); }

static void tb_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb) {
    (void)id;
    size_t n = qemu_plugin_tb_n_insns(tb);
    for (size_t i = 0; i < n; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, i);
        /* Registered before the counter, so a mark's count excludes the marked instruction. */
        if (qemu_plugin_insn_vaddr(insn) == mark)
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_mark, QEMU_PLUGIN_CB_NO_REGS, NULL);
        qemu_plugin_register_vcpu_insn_exec_inline_per_vcpu(insn, QEMU_PLUGIN_INLINE_ADD_U64, count, 1);
    }
}

static void at_exit(qemu_plugin_id_t id, void *user) { (void)id; (void)user; say("PLUGIN_TOTAL"); }

__attribute__((visibility("default")))
int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv) {
    (void)info;
    for (int i = 0; i < argc; i++)
        if (!strncmp(argv[i], "mark=", 5)) mark = strtoull(argv[i] + 5, NULL, 0);
    if (mark == ~0ull) {
        fprintf(stderr, "icount plugin: missing mark=0xADDRESS\n");
        return -1;
    }
    count.score = qemu_plugin_scoreboard_new(sizeof(uint64_t));
    count.offset = 0;
    qemu_plugin_register_vcpu_tb_trans_cb(id, tb_trans);
    qemu_plugin_register_atexit_cb(id, at_exit, NULL);
    return 0;
}
