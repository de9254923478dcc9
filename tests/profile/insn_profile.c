/*
 * insn_profile: a QEMU TCG plugin that profiles a Cortex-M program in the
 * STM32F405's flash, exactly:
 *   - how often each instruction executes (self cost per address), and
 *   - for each call instruction (BL, BLX Rm), how many times it ran and
 *     how many instructions the callee executed in all until it returned
 *     (inclusive cost per call site, from a shadow call stack).
 * At exit it writes to out=PATH:
 *   "i ADDRESS COUNT"              per executed instruction
 *   "c ADDRESS CALLS INSTRUCTIONS" per executed call site
 * scripts/profile.sh turns that into a breakdown of Monitor::step.
 *
 * Build: gcc -shared -fPIC -O2 -fvisibility=hidden -o insn_profile.so insn_profile.c
 * Run:   qemu-system-arm ... -plugin ./insn_profile.so,out=profile.txt
 *
 * The few declarations of QEMU's plugin API it needs (API version 1, as
 * in QEMU 7.x; see QEMU's docs/devel/tcg-plugins.rst) are spelled out
 * below, so no QEMU development headers are required.
 */
#include <stdint.h>
#include <stdio.h>
#include <string.h>

typedef uint64_t qemu_plugin_id_t;
typedef struct qemu_info_t qemu_info_t;
struct qemu_plugin_tb;
struct qemu_plugin_insn;
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 = 0 };
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS = 0 };
typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t, struct qemu_plugin_tb *);
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t, void *);
typedef void (*qemu_plugin_vcpu_udata_cb_t)(unsigned int, void *);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t, qemu_plugin_vcpu_tb_trans_cb_t);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *);
struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *, size_t);
uint64_t qemu_plugin_insn_vaddr(const struct qemu_plugin_insn *);
const void *qemu_plugin_insn_data(const struct qemu_plugin_insn *);
size_t qemu_plugin_insn_size(const struct qemu_plugin_insn *);
void qemu_plugin_register_vcpu_insn_exec_inline(struct qemu_plugin_insn *, enum qemu_plugin_op,
                                                void *, uint64_t);
void qemu_plugin_register_vcpu_insn_exec_cb(struct qemu_plugin_insn *, qemu_plugin_vcpu_udata_cb_t,
                                            enum qemu_plugin_cb_flags, void *);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t, qemu_plugin_udata_cb_t, void *);

#define EXPORT __attribute__((visibility("default")))
EXPORT int qemu_plugin_version = 1;

#define FLASH_BASE 0x08000000u
#define FLASH_SIZE (1u << 20)
#define SLOTS (FLASH_SIZE / 2) /* Thumb: one slot per halfword */
#define MAX_DEPTH 256

static uint64_t counts[SLOTS];   /* executions per instruction */
static uint64_t calls[SLOTS];    /* executions per call site */
static uint64_t inclusive[SLOTS]; /* callee instructions per call site */
static uint8_t is_return_site[SLOTS];
static uint64_t total;           /* all instructions executed */
static uint64_t outside;
static struct { uint32_t ret; uint32_t site; uint64_t start; } stack[MAX_DEPTH];
static int depth;
static uint64_t overflow;
static char out_path[4096] = "insn_profile.txt";

static int in_flash(uint64_t pc) { return pc >= FLASH_BASE && pc < FLASH_BASE + FLASH_SIZE; }
static uint32_t slot(uint64_t pc) { return (uint32_t)((pc - FLASH_BASE) / 2); }

static void on_call(unsigned int vcpu, void *udata)
{
    (void)vcpu;
    uint32_t site = (uint32_t)(uintptr_t)udata;
    uint32_t size = site & 1 ? 2 : 4; /* low bit tags a 16-bit BLX Rm */
    site &= ~1u;
    if (depth == MAX_DEPTH) {
        overflow++;
        return;
    }
    stack[depth].ret = site + size;
    stack[depth].site = site;
    stack[depth].start = total;
    depth++;
}

static void on_return_site(unsigned int vcpu, void *udata)
{
    (void)vcpu;
    uint32_t pc = (uint32_t)(uintptr_t)udata;
    if (depth > 0 && stack[depth - 1].ret == pc) {
        depth--;
        uint32_t s = slot(stack[depth].site);
        calls[s]++;
        inclusive[s] += total - stack[depth].start;
    }
}

static void tb_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    (void)id;
    size_t n = qemu_plugin_tb_n_insns(tb);
    for (size_t i = 0; i < n; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, i);
        uint64_t pc = qemu_plugin_insn_vaddr(insn);
        qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, &total, 1);
        if (!in_flash(pc)) {
            qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, &outside, 1);
            continue;
        }
        qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64,
                                                   &counts[slot(pc)], 1);
        if (is_return_site[slot(pc)]) {
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_return_site, QEMU_PLUGIN_CB_NO_REGS,
                                                   (void *)(uintptr_t)pc);
        }
        const uint8_t *b = qemu_plugin_insn_data(insn);
        size_t size = qemu_plugin_insn_size(insn);
        uint16_t h1 = (uint16_t)(b[0] | b[1] << 8);
        int call = 0;
        if (size == 4) {
            uint16_t h2 = (uint16_t)(b[2] | b[3] << 8);
            call = (h1 & 0xF800) == 0xF000 && (h2 & 0xD000) == 0xD000; /* BL */
        } else if (size == 2) {
            call = (h1 & 0xFF87) == 0x4780; /* BLX Rm */
        }
        if (call) {
            uint64_t ret = pc + size;
            if (in_flash(ret)) {
                is_return_site[slot(ret)] = 1;
            }
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_call, QEMU_PLUGIN_CB_NO_REGS,
                                                   (void *)(uintptr_t)(pc | (size == 2)));
        }
    }
}

static void at_exit(qemu_plugin_id_t id, void *p)
{
    (void)id;
    (void)p;
    FILE *f = fopen(out_path, "w");
    if (!f) {
        perror(out_path);
        return;
    }
    for (uint32_t i = 0; i < SLOTS; i++) {
        if (counts[i]) {
            fprintf(f, "i %08x %llu\n", FLASH_BASE + 2 * i, (unsigned long long)counts[i]);
        }
        if (calls[i]) {
            fprintf(f, "c %08x %llu %llu\n", FLASH_BASE + 2 * i, (unsigned long long)calls[i],
                    (unsigned long long)inclusive[i]);
        }
    }
    fprintf(f, "total %llu\noutside %llu\nstack_overflow %llu\n", (unsigned long long)total,
            (unsigned long long)outside, (unsigned long long)overflow);
    fclose(f);
}

EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv)
{
    (void)info;
    for (int i = 0; i < argc; i++) {
        if (strncmp(argv[i], "out=", 4) == 0) {
            snprintf(out_path, sizeof out_path, "%s", argv[i] + 4);
        }
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, tb_trans);
    qemu_plugin_register_atexit_cb(id, at_exit, NULL);
    return 0;
}
