/* The header alone, compiled as C89 (-std=c89 -pedantic), as C++98, and with DCP_ALIGNED
 * defined by the caller (tests/c_host.rs): its macros are constant expressions a firmware can
 * size static buffers with, and dcp_model keeps its 8-byte alignment. A failed check here is
 * a negative array size, a compile error. */
#include <stddef.h>

#include "policy_core.h"

#define DCP_STATIC_CHECK(name, cond) typedef char name[(cond) ? 1 : -1]

/* The golden 4x48 actor and 2x32 critic (2 observations, 2 actions). */
static float actor_scratch[DCP_SCRATCH_FLOATS(DCP_SCRATCH_WIDTH_ACTOR(2, 2, 48))];
static float critic_scratch[DCP_SCRATCH_FLOATS(DCP_SCRATCH_WIDTH_CRITIC(2, 2, 32))];
static float discrete_scratch[DCP_SCRATCH_FLOATS(DCP_SCRATCH_WIDTH_DISCRETE(3, 2, 16, 40))];
static float any_scratch[DCP_SCRATCH_FLOATS(DCP_MAX_SCRATCH_WIDTH)];
static dcp_model model;
static dcp_boot boot;

DCP_STATIC_CHECK(actor_scratch_is_96_floats, sizeof actor_scratch == 96 * sizeof(float));
DCP_STATIC_CHECK(critic_scratch_is_64_floats, sizeof critic_scratch == 64 * sizeof(float));
DCP_STATIC_CHECK(discrete_scratch_is_80_floats, sizeof discrete_scratch == 80 * sizeof(float));
DCP_STATIC_CHECK(any_scratch_is_2560_floats, sizeof any_scratch == 2560 * sizeof(float));

struct model_probe {
    char c;
    dcp_model m;
};
DCP_STATIC_CHECK(dcp_model_is_8_aligned, offsetof(struct model_probe, m) == 8);
DCP_STATIC_CHECK(dcp_model_size, sizeof(dcp_model) == DCP_MODEL_BYTES);

int c89_boot(const uint8_t *a, size_t a_len, dcp_error *err);

int c89_boot(const uint8_t *a, size_t a_len, dcp_error *err) {
    int32_t status = DCP_ABI_CHECK(err);
    if (status != DCP_OK) {
        return (int)status;
    }
    status = dcp_slot_choose(a, a_len, NULL, 0, 2, 2, 48, &boot, &model, err);
    if (status != DCP_OK) {
        return (int)status;
    }
    return (int)dcp_act(&model, actor_scratch, 2, actor_scratch + 2, 94, critic_scratch, 2, err) +
           (int)(discrete_scratch[0] + any_scratch[0]);
}
