/*
 * cart_on_rail.c: an example plant for the plant link, a cart on a rail with hard ends.
 *
 *   observation [x, v, target]   x in [-1, 1], v in [-4, 4], target in [-0.8, 0.8]
 *   action      [force]          in [-1, 1]: an acceleration of 2 * force
 *
 * Each step of dt = 0.05 s: v += a dt, then x += v dt (semi-implicit Euler: a cart pushed into
 * an end stays against it rather than bouncing off the stop every other step). A cart that
 * reaches an end is stopped dead there (v = 0): the step touched the margin. The reward is
 * minus the distance to the target, plus 0.5 on each step within 0.05 of it; the episode is
 * truncated at 200 steps and never terminates; success is being within 0.05 of the target for
 * the last 10 steps. The start and the target come from the reset seed alone (splitmix64), so
 * a seed gives the same episode on any machine with IEEE-754 floats.
 *
 * Build: cc -std=c99 -O2 -o cart_on_rail cart_on_rail.c plant_link.c   (or make)
 * Run:   firmware-sim run --plant-cmd ./cart_on_rail --blob policy.postcard
 */
#include "plant_link.h"

#include <stdio.h>

#define CART_DT 0.05f
#define CART_ACCEL 2.0f
#define CART_END 1.0f
#define CART_START 0.8f
#define CART_SPEED_BOX 4.0f
#define CART_STEPS 200u
#define CART_HOLD_RADIUS 0.05f
#define CART_HOLD_STEPS 10u
#define CART_OBSERVATIONS 3u

static const float cart_observation_low[CART_OBSERVATIONS] = {-CART_END, -CART_SPEED_BOX, -CART_START};
static const float cart_observation_high[CART_OBSERVATIONS] = {CART_END, CART_SPEED_BOX, CART_START};
static const float cart_action_low[1] = {-1.0f};
static const float cart_action_high[1] = {1.0f};

static const pl_agent cart_agent = {
    .name = "cart",
    .observation_low = cart_observation_low,
    .observation_high = cart_observation_high,
    .action_low = cart_action_low,
    .action_high = cart_action_high,
    .observation_len = CART_OBSERVATIONS,
    .action_len = 1,
};

typedef struct {
    float x, v, target;
    unsigned steps, held;
    int started; /* a reset has been answered: steps before one are refused */
} cart;

/* One answer, before it is framed: the fault plant alters it on its way out. */
typedef struct {
    pl_request_kind answer; /* PL_HELLO, PL_RESET or PL_STEP, when error is empty */
    char error[96];
    float observation[CART_OBSERVATIONS];
    uint32_t observation_len;
    float reward;
    int truncated, margin_touched, success;
    float applied;
} cart_reply;

static uint64_t splitmix64(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15u);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9u;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBu;
    return z ^ (z >> 31);
}

/* Uniform in [lo, hi): 24 random bits, exactly representable in a float. */
static float uniform(uint64_t *state, float lo, float hi)
{
    float u = (float)(splitmix64(state) >> 40) / 16777216.0f;
    return lo + (hi - lo) * u;
}

static float distance(float a, float b)
{
    return a > b ? a - b : b - a;
}

static void cart_reset(cart *c, uint64_t seed)
{
    uint64_t state = seed;
    c->x = uniform(&state, -CART_START, CART_START);
    c->target = uniform(&state, -CART_START, CART_START);
    c->v = 0.0f;
    c->steps = 0;
    c->held = 0;
    c->started = 1;
}

static void cart_observe(const cart *c, cart_reply *r)
{
    r->observation[0] = c->x;
    r->observation[1] = c->v;
    r->observation[2] = c->target;
    r->observation_len = CART_OBSERVATIONS;
}

static void cart_step(cart *c, float action, cart_reply *r)
{
    /* The host sends finite actions inside the box; a plant guards its motor anyway. */
    float force = action != action ? 0.0f : action > 1.0f ? 1.0f : action < -1.0f ? -1.0f : action;
    float d;
    int at_end = 0;
    c->v += CART_ACCEL * force * CART_DT;
    c->x += c->v * CART_DT;
    if (c->x >= CART_END || c->x <= -CART_END) {
        at_end = c->x > 0.0f ? 1 : -1;
        c->x = at_end * CART_END;
        c->v = 0.0f;
    }
    /* applied is the force actually applied, in action units: the commanded force, or 0 when
     * the cart ends the step against an end and the force pushes into it, since the end stop
     * then takes that force and the cart does not move. A policy that parks against an end
     * thus sees its action do nothing, which is what the margin-safe trainer learns from. */
    r->applied = at_end != 0 && force * (float)at_end > 0.0f ? 0.0f : force;
    r->margin_touched = at_end != 0;
    c->steps++;
    d = distance(c->x, c->target);
    c->held = d <= CART_HOLD_RADIUS ? c->held + 1 : 0;
    r->reward = -d + (d <= CART_HOLD_RADIUS ? 0.5f : 0.0f);
    r->truncated = c->steps >= CART_STEPS;
    r->success = c->held >= CART_HOLD_STEPS;
    cart_observe(c, r);
}

/* The cart's answer to a request other than Close (which the serving loop handles). */
static void cart_answer(cart *c, const pl_request *req, cart_reply *r)
{
    r->error[0] = '\0';
    r->answer = req->kind;
    switch (req->kind) {
    case PL_RESET:
        cart_reset(c, req->seed);
        cart_observe(c, r);
        break;
    case PL_STEP:
        if (!c->started) {
            snprintf(r->error, sizeof r->error, "a step before any reset");
        } else if (req->action_len != 1) {
            snprintf(r->error, sizeof r->error, "an action of %u values, expected 1",
                     (unsigned)req->action_len);
        } else {
            cart_step(c, req->action[0], r);
        }
        break;
    case PL_HELLO:
    case PL_CLOSE:
        break;
    }
}

static pl_status cart_send(const cart_reply *r, FILE *out)
{
    pl_step step;
    if (r->error[0] != '\0') {
        return pl_send_error(out, r->error);
    }
    switch (r->answer) {
    case PL_HELLO:
        return pl_send_hello(out, "cart-on-rail", &cart_agent, 1);
    case PL_RESET:
        return pl_send_reset(out, r->observation, r->observation_len);
    case PL_STEP:
        step.observation_len = r->observation_len;
        step.observation = r->observation;
        step.reward = r->reward;
        step.terminated = 0;
        step.truncated = r->truncated;
        step.margin_touched = r->margin_touched;
        step.applied_len = 1;
        step.applied = &r->applied;
        step.success = r->success;
        return pl_send_step(out, &step);
    case PL_CLOSE:
        break;
    }
    return PL_OK;
}

/* A request that does not decode is answered with an Error naming why; the host stops then. */
static pl_status cart_refuse(pl_status why, FILE *out)
{
    char message[160];
    snprintf(message, sizeof message, "cart-on-rail could not read the request: %s",
             pl_status_text(why));
    return pl_send_error(out, message);
}

#ifndef CART_ON_RAIL_NO_MAIN
int main(void)
{
    cart c = {0.0f, 0.0f, 0.0f, 0, 0, 0};
    pl_request req;
    cart_reply reply;
    for (;;) {
        pl_status s = pl_read_request(stdin, &req);
        if (s == PL_EOF) {
            return 0; /* the host is gone */
        }
        if (s == PL_IO) {
            return 1;
        }
        if (s != PL_OK) {
            s = cart_refuse(s, stdout);
        } else if (req.kind == PL_CLOSE) {
            return 0;
        } else {
            cart_answer(&c, &req, &reply);
            s = cart_send(&reply, stdout);
        }
        if (s != PL_OK) {
            return 1; /* the host stopped reading */
        }
    }
}
#endif
