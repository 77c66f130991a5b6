/* The C side of tests/c_host.rs: a C program built against the committed include/policy_core.h
 * and the host libpolicy_core_ffi.a. It feeds the library bad input and prints the codes, then
 * acts on observations and prints the results as f32 bits; the Rust test compares everything
 * with policy-core.
 *
 * usage: host_check ACTOR_BLOB CRITIC_BLOB OBSERVATIONS SLOT_A SLOT_B
 *   OBSERVATIONS: lines "OBS_BITS0 OBS_BITS1" (f32 bits in hex)
 *   SLOT_A, SLOT_B: slot images (a slot record each)
 * output lines:
 *   SIZE name bytes              the C compiler's sizeof/alignment of each API type
 *   CODE case code name ...      the status of one call (and its dcp_error numbers)
 *   BOOT ..., REASON B ...       what dcp_slot_choose reported
 *   ACT k bits0 bits1            dcp_act on the actor
 *   Q k bits                     dcp_q on the critic (unit action = the observation / 4)
 */
#include <stdalign.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "policy_core.h"

static uint8_t *read_file(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "cannot open %s\n", path);
        exit(2);
    }
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    /* uint64_t storage: 8-aligned, as a blob in flash would be at least 4-aligned. */
    uint64_t *buf = calloc((size_t)n / 8 + 1, 8);
    if (!buf || fread(buf, 1, (size_t)n, f) != (size_t)n) {
        fprintf(stderr, "cannot read %s\n", path);
        exit(2);
    }
    fclose(f);
    *len = (size_t)n;
    return (uint8_t *)buf;
}

static uint32_t bits(float v) {
    uint32_t b;
    memcpy(&b, &v, sizeof b);
    return b;
}

static void code(const char *name, int32_t status, const dcp_error *err) {
    printf("CODE %s %d %s", name, (int)status, dcp_status_name(status));
    if (err) {
        printf(" needed=%zu found=%zu expected=%zu what=\"%s\" err_code=%d", err->needed, err->found,
               err->expected, err->what, (int)err->code);
    }
    printf("\n");
}

int main(int argc, char **argv) {
    if (argc != 6) {
        fprintf(stderr, "usage: host_check ACTOR_BLOB CRITIC_BLOB OBSERVATIONS SLOT_A SLOT_B\n");
        return 2;
    }
    size_t actor_len, critic_len;
    uint8_t *actor = read_file(argv[1], &actor_len);
    uint8_t *critic = read_file(argv[2], &critic_len);

    printf("SIZE dcp_error %zu\n", sizeof(dcp_error));
    printf("SIZE dcp_header %zu\n", sizeof(dcp_header));
    printf("SIZE dcp_model %zu\n", sizeof(dcp_model));
    printf("SIZE dcp_model_align %zu\n", alignof(dcp_model));
    printf("SIZE dcp_boot %zu\n", sizeof(dcp_boot));

    dcp_error err;
    dcp_header header;
    static dcp_model zeroed; /* a static: zero-initialised, never loaded */
    dcp_model actor_model = {0}, critic_model = {0};
    float scratch[256];
    float action[2];
    float obs[2] = {0.5f, -0.25f};
    float obs3[3] = {0.5f, -0.25f, 1.0f};

    /* Bad input: each call's code. */
    code("verify_null_blob", dcp_verify(NULL, actor_len, &header, &err), &err);
    code("verify_null_out", dcp_verify(actor, actor_len, NULL, NULL), NULL);
    code("verify_short", dcp_verify(actor, actor_len - 1, &header, &err), &err);
    code("verify_long", dcp_verify(actor, actor_len + 1, &header, &err), &err);
    actor[actor_len / 2] ^= 0x10;
    code("verify_flipped", dcp_verify(actor, actor_len, &header, &err), &err);
    actor[actor_len / 2] ^= 0x10;
    code("act_zeroed_model", dcp_act(&zeroed, obs, 2, scratch, 256, action, 2, &err), &err);
    code("load_actor", dcp_model_load(actor, actor_len, &actor_model, &err), &err);
    code("load_critic", dcp_model_load(critic, critic_len, &critic_model, &err), &err);
    code("for_policy_critic",
         dcp_model_for_policy(critic, critic_len, 2, 2, 64, &zeroed, &err), &err);
    code("act_null_obs", dcp_act(&actor_model, NULL, 2, scratch, 256, action, 2, &err), &err);
    code("act_null_scratch", dcp_act(&actor_model, obs, 2, NULL, 256, action, 2, &err), &err);
    code("act_null_action", dcp_act(&actor_model, obs, 2, scratch, 256, NULL, 2, &err), &err);
    code("act_obs_len", dcp_act(&actor_model, obs3, 3, scratch, 256, action, 2, &err), &err);
    code("act_action_len", dcp_act(&actor_model, obs, 2, scratch, 256, action, 1, &err), &err);
    code("act_scratch_short", dcp_act(&actor_model, obs, 2, scratch, 95, action, 2, &err), &err);
    code("act_on_critic", dcp_act(&critic_model, obs, 2, scratch, 256, action, 2, &err), &err);
    code("act_overlap", dcp_act(&actor_model, scratch, 2, scratch, 256, action, 2, &err), &err);
    uint32_t index;
    code("choose_on_actor", dcp_choose(&actor_model, obs, 2, scratch, 256, &index, &err), &err);
    float rows[4];
    code("choice_q_on_actor", dcp_choice_q(&actor_model, obs, 2, scratch, 256, rows, 4, &err), &err);
    size_t floats = 0;
    code("scratch_floats", dcp_scratch_floats(&actor_model, &floats, &err), &err);
    printf("FLOATS %zu\n", floats);

    /* Slots (images from the Rust test): A holds the actor (sequence 1), B the critic
     * (sequence 2: newer, but refused as a policy), so A runs. */
    size_t a_len, b_len;
    uint8_t *slot_a = read_file(argv[4], &a_len);
    uint8_t *slot_b = read_file(argv[5], &b_len);
    dcp_boot boot;
    dcp_model slot_model = {0};
    code("slot_choose", dcp_slot_choose(slot_a, a_len, slot_b, b_len, 2, 2, 64, &boot, &slot_model,
                                        &err), &err);
    printf("BOOT running=%u a=%u/%u b=%u/%d\n", (unsigned)boot.running, (unsigned)boot.a.state,
           (unsigned)boot.a.sequence, (unsigned)boot.b.state, (int)boot.b.error.code);
    printf("REASON B %s\n", boot.b.error.message);
    code("act_slot_model", dcp_act(&slot_model, obs, 2, scratch, 256, action, 2, &err), &err);
    uint8_t erased[64];
    memset(erased, 0xFF, sizeof erased);
    uint32_t seq;
    const uint8_t *blob_at;
    size_t blob_len;
    code("slot_read_erased", dcp_slot_read(erased, sizeof erased, &seq, &blob_at, &blob_len, &err),
         &err);
    code("slot_choose_erased", dcp_slot_choose(erased, sizeof erased, erased, sizeof erased, 2, 2,
                                               64, &boot, &slot_model, &err), &err);
    code("act_after_no_slot", dcp_act(&slot_model, obs, 2, scratch, 256, action, 2, &err), &err);
    free(slot_a);
    free(slot_b);

    /* Acting: every observation of the file through the actor and the critic. */
    FILE *f = fopen(argv[3], "r");
    if (!f) {
        fprintf(stderr, "cannot open %s\n", argv[3]);
        return 2;
    }
    unsigned int b0, b1;
    int k = 0;
    while (fscanf(f, "%x %x", &b0, &b1) == 2) {
        float o[2];
        uint32_t ob[2] = {b0, b1};
        memcpy(o, ob, sizeof o);
        int32_t s = dcp_act(&actor_model, o, 2, scratch, 96, action, 2, &err);
        if (s != DCP_OK) {
            fprintf(stderr, "act %d: %s\n", k, err.message);
            return 1;
        }
        printf("ACT %d %08x %08x\n", k, (unsigned)bits(action[0]), (unsigned)bits(action[1]));
        float unit[2] = {o[0] / 4.0f, o[1] / 4.0f};
        float q;
        s = dcp_q(&critic_model, o, 2, unit, 2, scratch, 256, &q, &err);
        if (s != DCP_OK) {
            fprintf(stderr, "q %d: %s\n", k, err.message);
            return 1;
        }
        printf("Q %d %08x\n", k, (unsigned)bits(q));
        k++;
    }
    fclose(f);
    free(actor);
    free(critic);
    return 0;
}
