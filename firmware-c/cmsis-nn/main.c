/* CMSIS-NN beside policy-core on the same integer actor, on the Cortex-M4F (QEMU mps2-an386):
   the whole forward pass through CMSIS-NN's arm_fully_connected_per_channel_s8 (row-major
   weights, the `SMLAD` kernel of ARM_MATH_DSP) and the tanh tables, and the same pass through
   policy-core's C API (dcp_act_codes, its own `SMLAD` kernel on column-major weights), each
   from the same input codes to unit codes, each between two fw_mark calls the QEMU plugin
   (firmware/qemu-plugin/icount.c) counts. net.h comes from `studies --bin cmsis-nn-header`:
   the layers in CMSIS-NN's layout, the blob, the input codes and the unit codes the host
   computes. Both results are checked against the host's, code for code.

   Marks, in order: 0 1 (the mark's own cost), then per case 2 3 (CMSIS-NN) and 4 5 (ours), then
   6 7 (the requantisation alone as CMSIS-NN's kernel writes it, over every output once).
   Built and run by scripts/bench-cmsis-nn.sh with the startup, console and link script of the
   example C firmware (firmware-c/). */
#include <stdint.h>
#include <string.h>

#include "arm_nnfunctions.h"
#include "arm_nnsupportfunctions.h"
#include "console.h"
#include "net.h"
#include "policy_core.h"

/* A call the QEMU plugin watches (as in firmware-c/main.c). `noipa`, not only `noinline`: at
   -Ofast GCC would otherwise call constant-argument clones (fw_mark.constprop.N) the plugin
   does not watch. */
__attribute__((noipa, used)) void fw_mark(uint32_t id) {
    __asm__ volatile("" : : "r"(id) : "memory");
}

static int8_t vectors[2][NET_WIDTH] __attribute__((aligned(4)));
static int32_t scratch[DCP_SCRATCH_FLOATS(DCP_SCRATCH_WIDTH_ACTOR(NET_OBSERVATIONS, NET_ACTIONS, NET_WIDTH))];
static dcp_model model;

/* The integer forward pass through CMSIS-NN: each layer one arm_fully_connected_per_channel_s8
   call (bias, products, requantisation, output offset, clamp), then the layer's table if it
   has one; the output layer's codes are the unit codes. */
static void cmsis_act(const int8_t *codes, int8_t *unit) {
    const int8_t *x = codes;
    for (int n = 0; n < NET_LAYERS; n++) {
        const struct net_layer *l = &NET[n];
        int8_t *y = vectors[n & 1];
        const cmsis_nn_context ctx = {0, 0}; /* the kernel sums are used by MVE only */
        const cmsis_nn_fc_params fc = {l->input_offset, 0, l->output_offset, {l->act_min, l->act_max}};
        const cmsis_nn_per_channel_quant_params q = {l->multiplier, l->shift};
        const cmsis_nn_dims in = {1, 1, 1, l->inputs};
        const cmsis_nn_dims filter = {l->inputs, 1, 1, l->outputs};
        const cmsis_nn_dims bias = {1, 1, 1, l->outputs};
        const cmsis_nn_dims out = {1, 1, 1, l->outputs};
        if (arm_fully_connected_per_channel_s8(&ctx, &fc, &q, &in, x, &filter, l->weights, &bias,
                                               l->bias, &out, y) != ARM_CMSIS_NN_SUCCESS) {
            fail("arm_fully_connected_per_channel_s8");
        }
        if (l->table) {
            for (int o = 0; o < l->outputs; o++) {
                y[o] = l->table[y[o] + 128];
            }
        }
        x = y;
    }
    memcpy(unit, x, NET_ACTIONS);
}

/* What CMSIS-NN's kernel does after the products, for every output of every layer once:
   arm_nn_requantize, the output offset, the clamp, the store. The accumulator is the bias,
   hidden from the compiler so that nothing folds. */
static void cmsis_requantise_only(void) {
    for (int n = 0; n < NET_LAYERS; n++) {
        const struct net_layer *l = &NET[n];
        for (int o = 0; o < l->outputs; o++) {
            int32_t acc = l->bias[o];
            __asm__ volatile("" : "+r"(acc));
            acc = arm_nn_requantize(acc, l->multiplier[o], l->shift[o]) + l->output_offset;
            acc = MAX(acc, l->act_min);
            vectors[0][o] = (int8_t)MIN(acc, l->act_max);
        }
    }
}

/* " " and a signed decimal. */
static void push_code(line *l, int32_t c) {
    char t[6];
    int at = 5;
    uint32_t u = c < 0 ? (uint32_t)-c : (uint32_t)c;
    t[at] = 0;
    do {
        t[--at] = (char)('0' + u % 10);
        u /= 10;
    } while (u != 0);
    if (c < 0) {
        t[--at] = '-';
    }
    t[--at] = ' ';
    line_push(l, &t[at]);
}

static void print_codes(line *l, const char *tag, const int8_t *codes) {
    line_push(l, tag);
    for (int k = 0; k < NET_ACTIONS; k++) {
        push_code(l, codes[k]);
    }
}

int main(void) {
    if (DCP_ABI_CHECK(NULL) != DCP_OK || dcp_model_load(NET_BLOB, NET_BLOB_LEN, &model, NULL) != DCP_OK) {
        fail("dcp_model_load");
    }
    int8_t theirs[NET_CASES][NET_ACTIONS], ours[NET_CASES][NET_ACTIONS];
    int32_t status[NET_CASES];
    fw_mark(0); /* span "overhead": two marks back to back */
    fw_mark(1);
    for (int k = 0; k < NET_CASES; k++) {
        fw_mark(2);
        cmsis_act(NET_INPUT_CODES[k], theirs[k]);
        fw_mark(3);
        fw_mark(4);
        status[k] = dcp_act_codes(&model, NET_INPUT_CODES[k], NET_OBSERVATIONS, scratch,
                                  sizeof scratch / sizeof scratch[0], ours[k], NET_ACTIONS, NULL);
        fw_mark(5);
    }
    fw_mark(6);
    cmsis_requantise_only();
    fw_mark(7);

    int failed = 0;
    for (int k = 0; k < NET_CASES; k++) {
        int cmsis_ok = memcmp(theirs[k], NET_UNIT_CODES[k], NET_ACTIONS) == 0;
        int ours_ok = status[k] == DCP_OK && memcmp(ours[k], NET_UNIT_CODES[k], NET_ACTIONS) == 0;
        line l;
        line_new(&l, cmsis_ok && ours_ok ? "CASE" : "MISMATCH");
        line_dec(&l, (uint32_t)k);
        print_codes(&l, " host", NET_UNIT_CODES[k]);
        print_codes(&l, " cmsis-nn", theirs[k]);
        print_codes(&l, " ours", ours[k]);
        line_emit(&l);
        failed |= !(cmsis_ok && ours_ok);
    }
    line l;
    line_new(&l, failed ? "FAIL codes differ (the MISMATCH lines)" : "DONE bit-exact");
    line_emit(&l);
    if (failed) {
        exit_failure();
    }
    exit_ok();
}
