/* A host program of policy-core's C API, built against the release folder's archive for this
 * machine: it shows the API on a PC (unit tests, a simulator, a team's CI) and checks the
 * archive against policy-core bit for bit, before any chip is involved.
 *
 *   act_check BLOB REFERENCE
 *
 * REFERENCE is what `host-trainer act --blob BLOB --obs ...` printed, one line per observation:
 * "obs0 obs1 ... -> action0 action1 ... [bits0 bits1 ...]" (a discrete policy's line goes on
 * with its choice and Q values, which are not read here). The program checks the library's ABI
 * version against the header's, loads the blob, acts on each line's observation and compares the
 * action's IEEE-754 bits with the line's.
 * Exit status: 0 = every action bit-exact, 1 = a difference, 2 = bad input or a refused blob. */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "policy_core.h"

#define MAX_LINE 4096
#define MAX_VALUES 256 /* the most observations or actions a reference line may carry */

static uint32_t bits_of(float x) {
    uint32_t bits;
    memcpy(&bits, &x, sizeof bits);
    return bits;
}

/* The whole file in memory (malloc's alignment keeps the blob 4-aligned, as the API asks), or
 * NULL. */
static uint8_t *read_file(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    uint8_t *bytes = NULL;
    long size = -1;
    if (f != NULL && fseek(f, 0, SEEK_END) == 0 && (size = ftell(f)) >= 0 && fseek(f, 0, SEEK_SET) == 0 &&
        (bytes = malloc(size > 0 ? (size_t)size : 1)) != NULL && fread(bytes, 1, (size_t)size, f) != (size_t)size) {
        free(bytes);
        bytes = NULL;
    }
    if (f != NULL) fclose(f);
    if (bytes == NULL) fprintf(stderr, "act_check: cannot read %s\n", path);
    *len = size > 0 ? (size_t)size : 0;
    return bytes;
}

/* One reference line: its observation (the numbers before "->", as host-trainer printed them:
 * shortest round-trip decimals, NaN, inf) and its action's bits (the hex words in brackets).
 * Returns 0, or -1 if the line is not of that form. */
static int parse_line(char *line, float *obs, size_t *n_obs, uint32_t *bits, size_t *n_bits) {
    char *arrow = strstr(line, "->"), *open, *p, *end;
    if (arrow == NULL || (open = strchr(arrow, '[')) == NULL || strchr(open, ']') == NULL) return -1;
    *arrow = '\0';
    for (p = line, *n_obs = 0;; p = end) {
        float x = strtof(p, &end);
        if (end == p) break;
        if (*n_obs == MAX_VALUES) return -1;
        obs[(*n_obs)++] = x;
    }
    while (*p == ' ') p++;
    if (*p != '\0') return -1;
    for (p = open + 1, *n_bits = 0;; p = end) {
        unsigned long word;
        errno = 0;
        word = strtoul(p, &end, 16);
        if (end == p) break;
        if (errno != 0 || word > 0xFFFFFFFFul || *n_bits == MAX_VALUES) return -1;
        bits[(*n_bits)++] = (uint32_t)word;
    }
    return *p == ']' && *n_bits > 0 ? 0 : -1;
}

int main(int argc, char **argv) {
    static dcp_model model; /* zeroed: "not loaded" until dcp_model_load fills it */
    static char line[MAX_LINE];
    float obs[MAX_VALUES], action[MAX_VALUES], *scratch;
    uint32_t expected[MAX_VALUES];
    size_t blob_len, scratch_len, n_obs, n_bits, i, cases = 0, differ = 0;
    int same;
    dcp_header header;
    dcp_error err;
    uint8_t *blob;
    FILE *reference;

    if (argc != 3) {
        fprintf(stderr, "usage: act_check BLOB REFERENCE (the output of host-trainer act)\n");
        return 2;
    }
    /* The archive linked in must be of the ABI version this header describes. */
    if (DCP_ABI_CHECK(&err) != DCP_OK) {
        fprintf(stderr, "act_check: %s\n", err.message);
        return 2;
    }
    if ((blob = read_file(argv[1], &blob_len)) == NULL) return 2;
    if (dcp_model_load(blob, blob_len, &model, &err) != DCP_OK || dcp_model_header(&model, &header, &err) != DCP_OK ||
        dcp_scratch_floats(&model, &scratch_len, &err) != DCP_OK) {
        fprintf(stderr, "act_check: %s refused: %s (%s)\n", argv[1], err.message, dcp_status_name(err.code));
        return 2;
    }
    if (header.kind == DCP_KIND_CRITIC || header.actions > MAX_VALUES) {
        fprintf(stderr, "act_check: expected an actor or a discrete policy of at most %d actions in %s\n", MAX_VALUES,
                argv[1]);
        return 2;
    }
    if ((scratch = malloc(scratch_len * sizeof *scratch)) == NULL || (reference = fopen(argv[2], "r")) == NULL) {
        fprintf(stderr, "act_check: cannot read %s\n", argv[2]);
        return 2;
    }
    printf("ABI %u, %s: %u observations, %u actions, scratch %u floats\n", (unsigned)dcp_abi_version(), header.label,
           (unsigned)header.observations, (unsigned)header.actions, (unsigned)scratch_len);
    while (fgets(line, sizeof line, reference) != NULL) {
        if (strchr(line, '\n') == NULL && !feof(reference)) {
            fprintf(stderr, "act_check: %s: a line longer than %d bytes\n", argv[2], MAX_LINE - 1);
            return 2;
        }
        if (parse_line(line, obs, &n_obs, expected, &n_bits) != 0 || n_obs != header.observations ||
            n_bits != header.actions) {
            fprintf(stderr, "act_check: %s:%u: expected \"%u observations -> %u actions [bits]\"\n", argv[2],
                    (unsigned)cases + 1, (unsigned)header.observations, (unsigned)header.actions);
            return 2;
        }
        if (dcp_act(&model, obs, n_obs, scratch, scratch_len, action, n_bits, &err) != DCP_OK) {
            fprintf(stderr, "act_check: dcp_act: %s\n", err.message);
            return 2;
        }
        printf("ACT %u", (unsigned)cases);
        for (i = 0, same = 1; i < n_bits; i++) {
            printf(" %08lx", (unsigned long)bits_of(action[i]));
            if (bits_of(action[i]) != expected[i]) {
                same = 0;
                differ++;
            }
        }
        printf("%s\n", same ? "" : "  DIFFERS from the reference");
        cases++;
    }
    fclose(reference);
    free(scratch);
    free(blob);
    if (cases == 0) {
        fprintf(stderr, "act_check: %s: no reference line\n", argv[2]);
        return 2;
    }
    if (differ > 0) {
        printf("MISMATCH: %u of %u actions' values differ from host-trainer act\n", (unsigned)differ,
               (unsigned)(cases * header.actions));
        return 1;
    }
    printf("MATCH: %u cases bit-exact with host-trainer act\n", (unsigned)cases);
    return 0;
}
