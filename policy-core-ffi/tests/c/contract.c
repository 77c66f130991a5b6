/* The C side of tests/c_host.rs's contract test: the promises of docs/c-api.md that only a C
 * program can check. Built with ASan and UBSan, and run again under valgrind (memcheck), which
 * reports any byte of a struct the library filled but left uninitialised.
 *
 * usage: contract ACTOR_BLOB CRITIC_BLOB SLOT_A
 * output: one "OK name" line per check, or "FAIL name: what" and exit status 1.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "policy_core.h"

static int failures = 0;

static void check(const char *name, int ok, const char *what) {
    if (ok) {
        printf("OK %s\n", name);
    } else {
        printf("FAIL %s: %s\n", name, what);
        failures++;
    }
}

static uint8_t *read_file(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    long n;
    uint64_t *buf;
    if (!f) {
        fprintf(stderr, "cannot open %s\n", path);
        exit(2);
    }
    fseek(f, 0, SEEK_END);
    n = ftell(f);
    fseek(f, 0, SEEK_SET);
    buf = calloc((size_t)n / 8 + 1, 8);
    if (!buf || fread(buf, 1, (size_t)n, f) != (size_t)n) {
        fprintf(stderr, "cannot read %s\n", path);
        exit(2);
    }
    fclose(f);
    *len = (size_t)n;
    return (uint8_t *)buf;
}

/* Reads every byte of a struct the library wrote: under valgrind an uninitialised byte (a
 * padding hole filled from the library's stack) makes this branch an error. */
static unsigned sum_bytes(const void *p, size_t n) {
    const unsigned char *b = p;
    unsigned sum = 0;
    size_t i;
    for (i = 0; i < n; i++) {
        if (b[i] & 1) {
            sum += b[i];
        }
    }
    return sum;
}

/* Structs from malloc (uninitialised, unlike a static): every byte must come from the library. */
static void padding(const uint8_t *actor, size_t actor_len, const uint8_t *slot_a, size_t a_len) {
    dcp_header *header = malloc(sizeof *header);
    dcp_error *err = malloc(sizeof *err);
    dcp_boot *boot = malloc(sizeof *boot);
    dcp_model *model = calloc(1, sizeof *model);
    uint8_t erased[64];
    unsigned sum = 0;
    memset(erased, 0xFF, sizeof erased);
    check("padding_verify", dcp_verify(actor, actor_len, header, err) == DCP_OK, "verify");
    sum += sum_bytes(header, sizeof *header) + sum_bytes(err, sizeof *err);
    check("padding_error", dcp_verify(actor, actor_len - 1, header, err) == DCP_ERR_TRUNCATED,
          "a short blob");
    sum += sum_bytes(err, sizeof *err);
    check("padding_boot", dcp_slot_choose(slot_a, a_len, erased, sizeof erased, 2, 2, 64, boot,
                                          model, err) == DCP_OK, "slot A runs");
    sum += sum_bytes(boot, sizeof *boot) + sum_bytes(err, sizeof *err);
    check("padding_reserved", header->reserved[0] == 0 && header->reserved[1] == 0 &&
          header->reserved[2] == 0 && err->reserved == 0 && boot->reserved == 0 &&
          boot->b.error.reserved == 0, "reserved fields are zero");
    printf("SUM %u\n", sum);
    free(header);
    free(err);
    free(boot);
    free(model);
}

/* A board with one slot: NULL and 0 for the other. */
static void one_slot(const uint8_t *slot_a, size_t a_len) {
    dcp_boot boot;
    dcp_error err;
    static dcp_model model;
    int32_t status = dcp_slot_choose(slot_a, a_len, NULL, 0, 2, 2, 64, &boot, &model, &err);
    check("one_slot", status == DCP_OK && boot.running == DCP_SLOT_A &&
          boot.b.error.code == DCP_ERR_SLOT_EMPTY, err.message);
}

/* The ABI check: this program's header against the library it is linked with. The Rust test
 * also builds it against a header whose DCP_ABI_VERSION was changed, which must be refused. */
static void abi(void) {
    dcp_error err;
    int32_t status = DCP_ABI_CHECK(&err);
    int same = DCP_ABI_VERSION == dcp_abi_version();
    printf("ABI header=%u library=%u status=%d %s\n", (unsigned)DCP_ABI_VERSION,
           (unsigned)dcp_abi_version(), (int)status, dcp_status_name(status));
    check("abi", status == (same ? DCP_OK : DCP_ERR_ABI_MISMATCH) &&
          (same || (err.expected == dcp_abi_version() && err.found == DCP_ABI_VERSION)),
          err.message);
}

/* The compile-time sizes are what the library reports for the golden blobs. */
static void sizes(const uint8_t *actor, size_t actor_len, const uint8_t *critic, size_t critic_len) {
    static float actor_scratch[DCP_SCRATCH_FLOATS(DCP_SCRATCH_WIDTH_ACTOR(2, 2, 48))];
    static float critic_scratch[DCP_SCRATCH_FLOATS(DCP_SCRATCH_WIDTH_CRITIC(2, 2, 32))];
    static dcp_model a, c;
    size_t a_floats = 0, c_floats = 0;
    dcp_header header;
    int ok = dcp_model_load(actor, actor_len, &a, NULL) == DCP_OK &&
             dcp_model_load(critic, critic_len, &c, NULL) == DCP_OK &&
             dcp_scratch_floats(&a, &a_floats, NULL) == DCP_OK &&
             dcp_scratch_floats(&c, &c_floats, NULL) == DCP_OK &&
             dcp_model_header(&a, &header, NULL) == DCP_OK;
    printf("SIZES actor=%zu/%zu critic=%zu/%zu\n", a_floats,
           sizeof actor_scratch / sizeof(float), c_floats, sizeof critic_scratch / sizeof(float));
    check("sizes", ok && a_floats == sizeof actor_scratch / sizeof(float) &&
          c_floats == sizeof critic_scratch / sizeof(float) &&
          header.scratch_width == DCP_SCRATCH_WIDTH_ACTOR(2, 2, 48), "macro and library differ");
}

int main(int argc, char **argv) {
    size_t actor_len, critic_len, a_len;
    uint8_t *actor, *critic, *slot_a;
    if (argc != 4) {
        fprintf(stderr, "usage: contract ACTOR_BLOB CRITIC_BLOB SLOT_A\n");
        return 2;
    }
    actor = read_file(argv[1], &actor_len);
    critic = read_file(argv[2], &critic_len);
    slot_a = read_file(argv[3], &a_len);
    abi();
    sizes(actor, actor_len, critic, critic_len);
    padding(actor, actor_len, slot_a, a_len);
    one_slot(slot_a, a_len);
    free(actor);
    free(critic);
    free(slot_a);
    return failures == 0 ? 0 : 1;
}
