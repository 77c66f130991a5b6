/* Example C firmware: a DCP policy running on a Cortex-M through policy-core's C API
 * (policy-core-ffi/include/policy_core.h, libpolicy_core_ffi.a), straight from flash.
 *
 * The part a user copies is short: boot() and control_step(). The firmware holds no blob: a
 * policy lives in one of two flash slots (firmware/mps2/memory.x); dcp_slot_choose picks the newer
 * slot whose blob verifies as a policy with this firmware's sizes and scratch width, falls back
 * to the other, and fills a dcp_model that reads its weights from the slot on every dcp_act.
 * The only RAM the policy uses is a scratch of 2 x W floats. Without a policy the firmware runs
 * the safe state, the zero action.
 *
 * Everything else measures what that costs, for scripts/cortex-m.sh, and prints the same lines
 * as the Rust firmware (firmware/src/main.rs) so that firmware/host-check checks and measures
 * both alike: which slot runs and why, the observations and actions as f32 bits (the host
 * recomputes them), fw_mark calls around each span a QEMU plugin counts, SysTick counts (the
 * fallback) and the stack's peak (painted). Built with -DMEASURE_CALLS it then measures the
 * stack of every call of the C API one by one (scripts/cortex-m.sh builds it both ways, so that
 * the measuring code stays out of the firmware's flash figures). QEMU's exit status is 0 only if
 * a slot's blob was accepted and every action is finite and inside the blob's bounds. */
#include <stddef.h>
#include <stdint.h>

#include "console.h"
#include "policy_core.h"

/* Observations the sensors give (x, y: the navigation task), actions the actuators take. */
#define OBS 2
#define ACT 2
/* Width of the activation scratch: the widest layer a blob may have to run here. It costs
 * 2 x W x 4 bytes of RAM (512 B for 64); a wider blob is refused at boot (safe state). */
#define W 64
#define CASES 10

/* The observations of firmware/src/observations.rs as f32 bits (NaN and the infinities are
 * exact this way); host-check compares what is printed with that file. */
static const uint32_t OBSERVATIONS[CASES][OBS] = {
    {0x00000000, 0x00000000}, /* 0, 0 */
    {0x3fc00000, 0xbf333333}, /* 1.5, -0.7 */
    {0x40800000, 0xc0200000}, /* 4, -2.5 */
    {0xc04ccccd, 0x4039999a}, /* -3.2, 2.9 */
    {0x3ebd70a4, 0x3ff47ae1}, /* 0.37, 1.91 */
    {0x41400000, 0xc2200000}, /* 12, -40 */
    {0x7fc00000, 0x3f800000}, /* NaN, 1 */
    {0x7f800000, 0xff800000}, /* inf, -inf */
    {0x80000000, 0x000ae398}, /* -0, 1e-39 (subnormal) */
    {0x7f7fffff, 0xff7fffff}, /* f32 max, -max */
};

/* The slots, from the linker script (firmware/mps2/memory.x). */
extern const uint8_t _slot_a[], _slot_b[];
extern const uint8_t _slot_size[];
/* The stack: painted from _stack_limit (end of .bss) up to the stack pointer. */
extern uint32_t _stack_limit[], _stack_top[];

static float scratch[2 * W];
static dcp_model model; /* zeroed (.bss): "not loaded" until boot fills it */

/* A call the QEMU plugin (firmware/qemu-plugin/icount.c) watches: it prints the running
 * instruction count each time this function is entered. Never inlined; the empty asm with a
 * memory clobber keeps the measured work from moving across a mark. */
__attribute__((noinline, used)) void fw_mark(uint32_t id) {
    __asm__ volatile("" : : "r"(id) : "memory");
}

/* Picks the slot to run and loads its policy into `model`: DCP_OK, or DCP_ERR_NO_SLOT (run the
 * safe state; `boot` says why each slot failed). */
static int32_t boot(const uint8_t *slot_a, const uint8_t *slot_b, size_t slot_size,
                    dcp_boot *out) {
    /* A library of another ABI version than this header: no slot runs (the safe state). */
    int32_t abi = DCP_ABI_CHECK(NULL);
    if (abi != DCP_OK) {
        *out = (dcp_boot){0};
        return abi;
    }
    return dcp_slot_choose(slot_a, slot_size, slot_b, slot_size, OBS, ACT, W, out, &model, NULL);
}

/* One control step: the policy's action, or the safe state (zero) without a model or on any
 * error. No dcp_error on the hot path: its message is built only when asked for. */
static void control_step(int running, const float obs[OBS], float action[ACT]) {
    if (!running || dcp_act(&model, obs, OBS, scratch, 2 * W, action, ACT, NULL) != DCP_OK) {
        for (int i = 0; i < ACT; i++) {
            action[i] = 0.0f;
        }
    }
}

/* --- measuring -------------------------------------------------------------------------- */

#define PAINT 0x5AFEC0DEu
#define SYST_CSR (*(volatile uint32_t *)0xE000E010)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018)

static inline __attribute__((always_inline)) uintptr_t stack_pointer(void) {
    uintptr_t sp;
    __asm__ volatile("mov %0, sp" : "=r"(sp));
    return sp;
}

static inline __attribute__((always_inline)) void paint(uintptr_t sp) {
    for (volatile uint32_t *at = _stack_limit; (uintptr_t)(at + 1) <= sp; at++) {
        *at = PAINT;
    }
}

static inline __attribute__((always_inline)) uint32_t used_below(uintptr_t sp) {
    volatile uint32_t *at = _stack_limit;
    while ((uintptr_t)(at + 1) <= sp && *at == PAINT) {
        at++;
    }
    return (uint32_t)(sp - (uintptr_t)at);
}

/* The fallback clock. QEMU's microbit models a SysTick that a real nRF51 (Cortex-M0) lacks; its
 * 16 MHz ticks are 62.5 instructions under -icount, so there the plugin's counts are the
 * figures. */
static void start_systick(void) {
    SYST_RVR = 0x00FFFFFF;
    SYST_CVR = 0;
    SYST_CSR = 5; /* core clock, enabled */
}

static uint32_t ticks(void) {
    return SYST_CVR;
}

/* SysTick ticks since t0 (it counts down, 24 bits). */
static uint32_t elapsed(uint32_t t0) {
    return (t0 - ticks()) & 0x00FFFFFF;
}

/* A loop of known length (2 instructions per turn): under QEMU's -icount this converts SysTick
 * ticks into instructions when the plugin is unavailable. Returns the ticks. The same two
 * instructions in Thumb-1 (Cortex-M0), where GCC hands inline assembly over in the older
 * "divided" syntax and a register r0-r7 ("l"). */
static uint32_t calibrate(uint32_t turns) {
    uint32_t t0 = ticks();
    __asm__ volatile(".syntax unified\n1: subs %0, %0, #1\n\tbne 1b" : "+l"(turns));
    return elapsed(t0);
}

static void print_slot(const char *name, const dcp_slot_status *s) {
    line l;
    line_new(&l, name);
    if (s->state == DCP_SLOT_RUNNING) {
        line_push(&l, " running");
        line_dec(&l, s->sequence);
    } else if (s->state == DCP_SLOT_STANDBY) {
        line_push(&l, " standby");
        line_dec(&l, s->sequence);
    } else {
        line_push(&l, " failed: ");
        line_push(&l, s->error.message);
    }
    line_emit(&l);
}

static uint32_t bits(float v) {
    uint32_t b;
    __builtin_memcpy(&b, &v, sizeof b);
    return b;
}

/* --- the stack of each call (-DMEASURE_CALLS) ------------------------------------------- */
#if defined(MEASURE_CALLS)

/* Two more slot records in the link script's probe regions, loaded as the slots are: a critic
 * and a discrete policy of this firmware's sizes, for the calls only those kinds take. A
 * region without a record (a firmware flashed with its slots only) skips those calls. */
extern const uint8_t _probe_critic[], _probe_discrete[], _probe_size[];

/* Paints the stack below the caller's stack pointer and returns that pointer. Inlined, so that
 * it is the pointer the caller's next call starts from: GCC's ARM frames are set up once in the
 * prologue, and stacked arguments lie above the pointer, in the caller's frame. */
static inline __attribute__((always_inline)) uintptr_t painted(void) {
    uintptr_t sp = stack_pointer();
    paint(sp);
    return sp;
}

/* "STACK_PHASE <call> <bytes>": what the call used below its caller's frame. The run fails
 * unless it returned `want` (a figure of a call that failed early would mean nothing). */
static void call_stack(const char *call, uint32_t bytes, int32_t got, int32_t want) {
    line l;
    if (got != want) {
        line_new(&l, "FAIL stack of ");
        line_push(&l, call);
        line_push(&l, ": status ");
        line_push(&l, dcp_status_name(got));
        line_emit(&l);
        exit_failure();
    }
    line_new(&l, "STACK_PHASE ");
    line_push(&l, call);
    line_dec(&l, bytes);
    line_emit(&l);
}

/* Runs `call` (an expression giving a status) on a freshly painted stack and prints its peak.
 * The stack is measured before call_stack's own frame is pushed. */
#define STACK_OF(name, want, call)                                                         \
    do {                                                                                   \
        uintptr_t at_ = painted();                                                         \
        int32_t got_ = (call);                                                             \
        call_stack((name), used_below(at_), got_, (want));                                 \
    } while (0)

/* Loads a probe region's record into `model`: DCP_OK, or why not (an empty region skips it). */
static int32_t load_probe(const uint8_t *region, uint32_t kind) {
    uint32_t sequence;
    const uint8_t *blob;
    size_t len;
    dcp_header header;
    size_t size = (size_t)(uintptr_t)_probe_size;
    if (dcp_slot_read(region, size, &sequence, &blob, &len, NULL) != DCP_OK) {
        return DCP_ERR_SLOT_EMPTY;
    }
    if (dcp_model_load(blob, len, &model, NULL) != DCP_OK ||
        dcp_model_header(&model, &header, NULL) != DCP_OK || header.kind != kind ||
        header.observations != OBS || header.actions != ACT) {
        fail("a probe region holds a record that is not a model of this kind and sizes");
    }
    return DCP_OK;
}

/* The stack of every call a firmware makes, each alone below this function's frame: on the
 * running slot's actor, then on the probe regions' critic and discrete policy. The error paths
 * are measured with a dcp_error to fill: building its message is the costly part. Reloads
 * `model` and rewrites `*boot`: nothing may use them afterwards. */
__attribute__((noinline)) static void measure_calls(const uint8_t *slot, size_t slot_size,
                                                    dcp_boot *boot) {
    uint32_t sequence, index;
    const uint8_t *blob;
    size_t len, floats;
    dcp_header header;
    dcp_error err;
    float obs[OBS], action[ACT], low[ACT], high[ACT], q[8];
    const float unit_action[ACT] = {0.5f, -0.5f};
    __builtin_memcpy(obs, OBSERVATIONS[1], sizeof obs);

    STACK_OF("dcp_abi_version", DCP_OK, dcp_abi_version() == DCP_ABI_VERSION ? DCP_OK : -1);
    STACK_OF("dcp_abi_check", DCP_OK, DCP_ABI_CHECK(NULL));
    STACK_OF("dcp_slot_choose", DCP_OK,
             dcp_slot_choose(_slot_a, slot_size, _slot_b, slot_size, OBS, ACT, W, boot, &model,
                             NULL));
    STACK_OF("dcp_slot_read", DCP_OK,
             dcp_slot_read(slot, slot_size, &sequence, &blob, &len, NULL));
    STACK_OF("dcp_verify", DCP_OK, dcp_verify(blob, len, &header, NULL));
    STACK_OF("dcp_model_load", DCP_OK, dcp_model_load(blob, len, &model, NULL));
    STACK_OF("dcp_model_for_policy", DCP_OK,
             dcp_model_for_policy(blob, len, OBS, ACT, W, &model, NULL));
    STACK_OF("dcp_model_header", DCP_OK, dcp_model_header(&model, &header, NULL));
    STACK_OF("dcp_scratch_floats", DCP_OK, dcp_scratch_floats(&model, &floats, NULL));
    STACK_OF("dcp_action_bounds", DCP_OK, dcp_action_bounds(&model, low, high, ACT, NULL));
    STACK_OF("dcp_act", DCP_OK, dcp_act(&model, obs, OBS, scratch, 2 * W, action, ACT, NULL));
    STACK_OF("dcp_status_name", DCP_OK,
             dcp_status_name(DCP_ERR_CHECKSUM_MISMATCH)[0] ? DCP_OK : -1);
    /* Errors with their details: a scratch too small on the hot path, and a blob for another
     * plant at load (verified in full, then refused with both sizes in the message). */
    STACK_OF("dcp_act+error", DCP_ERR_SCRATCH_TOO_SMALL,
             dcp_act(&model, obs, OBS, scratch, 2, action, ACT, &err));
    STACK_OF("dcp_model_for_policy+error", DCP_ERR_SIZE_MISMATCH,
             dcp_model_for_policy(blob, len, OBS + 1, ACT, W, &model, &err));

    if (load_probe(_probe_critic, DCP_KIND_CRITIC) == DCP_OK) {
        STACK_OF("dcp_q", DCP_OK,
                 dcp_q(&model, obs, OBS, unit_action, ACT, scratch, 2 * W, &q[0], NULL));
    }
    if (load_probe(_probe_discrete, DCP_KIND_DISCRETE) == DCP_OK) {
        size_t choices = dcp_model_header(&model, &header, NULL) == DCP_OK ? header.choices : 0;
        if (choices > sizeof q / sizeof q[0]) {
            fail("the probe's discrete policy has more choices than the firmware's buffer");
        }
        STACK_OF("dcp_choose", DCP_OK,
                 dcp_choose(&model, obs, OBS, scratch, 2 * W, &index, NULL));
        STACK_OF("dcp_choice_q", DCP_OK,
                 dcp_choice_q(&model, obs, OBS, scratch, 2 * W, q, choices, NULL));
    }
}
#endif

int main(void) {
    uintptr_t sp = stack_pointer();
    paint(sp);
    start_systick();
    const uint32_t cal_turns = 100000;
    uint32_t cal_ticks = calibrate(cal_turns);

    fw_mark(0); /* span "overhead": two marks back to back */
    fw_mark(1);

    dcp_boot booted;
    uint32_t t0 = ticks();
    fw_mark(2);
    int32_t status = boot(_slot_a, _slot_b, (size_t)(uintptr_t)_slot_size, &booted);
    fw_mark(3);
    uint32_t boot_ticks = elapsed(t0);
    uint32_t boot_stack = used_below(sp);
    int running = status == DCP_OK;

    paint(sp);
    float observations[CASES][OBS];
    __builtin_memcpy(observations, OBSERVATIONS, sizeof observations);
    float actions[CASES][ACT];
    t0 = ticks();
    for (int k = 0; k < CASES; k++) {
        fw_mark(4);
        control_step(running, observations[k], actions[k]);
        fw_mark(5);
    }
    uint32_t act_ticks = elapsed(t0);
    uint32_t act_stack = used_below(sp);

    line l;
    print_slot("SLOT A", &booted.a);
    print_slot("SLOT B", &booted.b);
    line_new(&l, "RUNNING ");
    line_push(&l, booted.running == DCP_SLOT_A ? "A" : booted.running == DCP_SLOT_B ? "B" : "safe");
    line_emit(&l);

    uint32_t blob_bytes = 0;
    dcp_header header;
    if (running && dcp_model_header(&model, &header, NULL) == DCP_OK) {
        line_new(&l, "SHAPE");
        line_dec(&l, header.depth);
        line_dec(&l, header.width);
        line_dec(&l, header.observations);
        line_dec(&l, header.actions);
        line_emit(&l);
        blob_bytes = header.blob_len;
    }
    line_new(&l, "SCRATCH_BYTES");
    line_dec(&l, sizeof scratch);
    line_emit(&l);
    line_new(&l, "BLOB_BYTES");
    line_dec(&l, blob_bytes);
    line_emit(&l);
    for (int k = 0; k < CASES; k++) {
        line_new(&l, "OBS");
        line_dec(&l, (uint32_t)k);
        line_hex(&l, OBSERVATIONS[k][0]);
        line_hex(&l, OBSERVATIONS[k][1]);
        line_emit(&l);
        line_new(&l, "ACT");
        line_dec(&l, (uint32_t)k);
        line_hex(&l, bits(actions[k][0]));
        line_hex(&l, bits(actions[k][1]));
        line_emit(&l);
    }
    line_new(&l, "SPAN overhead 1");
    line_emit(&l);
    line_new(&l, "SPAN boot 1");
    line_emit(&l);
    for (int k = 0; k < CASES; k++) {
        line_new(&l, "SPAN act");
        line_dec(&l, (uint32_t)k);
        line_emit(&l);
    }
    line_new(&l, "STACK_MAIN");
    line_dec(&l, (uint32_t)((uintptr_t)_stack_top - sp));
    line_emit(&l);
    line_new(&l, "STACK_PHASE boot");
    line_dec(&l, boot_stack);
    line_emit(&l);
    line_new(&l, "STACK_PHASE act");
    line_dec(&l, act_stack);
    line_emit(&l);
    line_new(&l, "TICKS_CAL");
    line_dec(&l, 2 * cal_turns);
    line_dec(&l, cal_ticks);
    line_emit(&l);
    line_new(&l, "TICKS boot 1");
    line_dec(&l, boot_ticks);
    line_emit(&l);
    line_new(&l, "TICKS act");
    line_dec(&l, CASES);
    line_dec(&l, act_ticks);
    line_emit(&l);

    if (!running) {
        line_new(&l, "FAIL boot: no slot holds a policy this firmware can run (safe state)");
        line_emit(&l);
        exit_failure();
    }
    /* dcp_act promises finite actions inside the blob's bounds for every observation. */
    float low[ACT], high[ACT];
    if (dcp_action_bounds(&model, low, high, ACT, NULL) != DCP_OK) {
        fail("the running model has no action bounds");
    }
    for (int k = 0; k < CASES; k++) {
        for (int i = 0; i < ACT; i++) {
            float a = actions[k][i];
            if (!(a >= low[i] && a <= high[i])) { /* false for NaN too */
                fail("an action is non-finite or outside the bounds");
            }
        }
    }
#if defined(MEASURE_CALLS)
    /* Last: it reloads `model`. */
    measure_calls(booted.running == DCP_SLOT_A ? _slot_a : _slot_b, (size_t)(uintptr_t)_slot_size,
                  &booted);
#endif
    line_new(&l, "DONE");
    line_emit(&l);
    exit_ok();
}
