/* The C side of tests/c_host.rs's contract test: the promises of docs/c-api.md that only a C
 * program can check. Built with ASan and UBSan, and run again under valgrind (memcheck), which
 * reports any byte of a struct the library filled but left uninitialised.
 *
 * usage: contract ACTOR_BLOB SLOT_A
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

int main(int argc, char **argv) {
    size_t actor_len, a_len;
    uint8_t *actor, *slot_a;
    if (argc != 3) {
        fprintf(stderr, "usage: contract ACTOR_BLOB SLOT_A\n");
        return 2;
    }
    actor = read_file(argv[1], &actor_len);
    slot_a = read_file(argv[2], &a_len);
    padding(actor, actor_len, slot_a, a_len);
    one_slot(slot_a, a_len);
    free(actor);
    free(slot_a);
    return failures == 0 ? 0 : 1;
}
