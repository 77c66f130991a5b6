/*
 * faulty_plant.c: the cart on a rail, misbehaving on request, for the host's fault tests
 * (firmware-sim/tests/plant_faults.rs). Until its fault it is the cart exactly, so a test
 * knows what the host saw before the fault and that the fault alone made it fail.
 *
 *   --exit-at-start          exit with status 3 before reading anything
 *   --exit-at-step N         exit with status 3 on reading step N (counted from each reset)
 *   --hang-at-step N         on reading step N, sleep forever without reading
 *   --garbage-at-step N      answer step N with bytes that are no frame
 *   --version V              frame every answer under protocol version V
 *   --box KIND               a hello with a bad box: empty, inverted, infinite, nan, mismatched
 *   --agents N               a hello declaring N copies of the cart's agent
 *   --wrong-size-at-step N   answer step N with an observation of 2 values, not 3
 *   --nan-at-step N          answer step N with a NaN in the observation
 *   --inf-reward-at-step N   answer step N with an infinite reward
 *   --error-at-step N        answer step N with Error{"the cart's motor driver tripped"}
 *   --ignore-close           stay on after Close; leave only when the input ends
 *
 * Build: cc -std=c99 -I.. -o faulty_plant faulty_plant.c ../plant_link.c
 */
#define _POSIX_C_SOURCE 200809L /* sleep() for the hang */

#define CART_ON_RAIL_NO_MAIN
/* The cart itself, compiled in: the fault plant must be the same plant up to its fault. */
#include "../cart_on_rail.c"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef struct {
    int exit_at_start, ignore_close;
    unsigned exit_at, hang_at, garbage_at, wrong_size_at, nan_at, inf_reward_at, error_at;
    unsigned version, agents;
    const char *box;
} faults;

static unsigned number(const char *flag, const char *text)
{
    char *end;
    unsigned long n = strtoul(text != NULL ? text : "", &end, 10);
    if (text == NULL || *text == '\0' || *end != '\0' || n == 0 || n > 65535u) {
        fprintf(stderr, "faulty_plant: %s takes a number from 1 to 65535\n", flag);
        exit(2);
    }
    return (unsigned)n;
}

static faults parse(int argc, char **argv)
{
    faults f;
    int i;
    memset(&f, 0, sizeof f);
    f.version = PL_VERSION;
    f.agents = 1;
    for (i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--exit-at-start") == 0) {
            f.exit_at_start = 1;
            continue;
        }
        if (strcmp(a, "--ignore-close") == 0) {
            f.ignore_close = 1;
            continue;
        }
        i++;
        if (strcmp(a, "--exit-at-step") == 0) f.exit_at = number(a, v);
        else if (strcmp(a, "--hang-at-step") == 0) f.hang_at = number(a, v);
        else if (strcmp(a, "--garbage-at-step") == 0) f.garbage_at = number(a, v);
        else if (strcmp(a, "--wrong-size-at-step") == 0) f.wrong_size_at = number(a, v);
        else if (strcmp(a, "--nan-at-step") == 0) f.nan_at = number(a, v);
        else if (strcmp(a, "--inf-reward-at-step") == 0) f.inf_reward_at = number(a, v);
        else if (strcmp(a, "--error-at-step") == 0) f.error_at = number(a, v);
        else if (strcmp(a, "--version") == 0) f.version = number(a, v);
        else if (strcmp(a, "--agents") == 0) f.agents = number(a, v);
        else if (strcmp(a, "--box") == 0 && v != NULL) f.box = v;
        else {
            fprintf(stderr, "faulty_plant: unknown argument %s\n", a);
            exit(2);
        }
    }
    return f;
}

/* The hello: the cart's, with the requested boxes spoilt and agents repeated. */
static pl_status send_hello(const faults *f, pl_writer *w)
{
    static const float nan_low[CART_OBSERVATIONS] = {NAN, -CART_SPEED_BOX, -CART_START};
    static const float one[1] = {1.0f}, minus_one[1] = {-1.0f}, half[1] = {0.5f};
    static const float infinite[1] = {INFINITY};
    pl_agent agents[4];
    unsigned i;
    if (f->agents > 4) {
        return PL_TOO_MANY_VALUES;
    }
    for (i = 0; i < f->agents; i++) {
        agents[i] = cart_agent;
    }
    if (f->box == NULL) {
    } else if (strcmp(f->box, "empty") == 0) {
        agents[0].action_low = half;
        agents[0].action_high = half;
    } else if (strcmp(f->box, "inverted") == 0) {
        agents[0].action_low = one;
        agents[0].action_high = minus_one;
    } else if (strcmp(f->box, "infinite") == 0) {
        agents[0].action_high = infinite;
    } else if (strcmp(f->box, "nan") == 0) {
        agents[0].observation_low = nan_low;
    } else if (strcmp(f->box, "mismatched") == 0) {
        /* pl_agent cannot say it (one length per box), so the body is written by hand. */
        pl_writer_init(w);
        pl_put_varint(w, 0);
        pl_put_str(w, "cart-on-rail");
        pl_put_varint(w, 1);
        pl_put_str(w, "cart");
        pl_put_f32s(w, cart_observation_low, 3);
        pl_put_f32s(w, cart_observation_high, 2);
        pl_put_f32s(w, cart_action_low, 1);
        pl_put_f32s(w, cart_action_high, 1);
        return pl_send_version(stdout, w, (uint16_t)f->version);
    } else {
        fprintf(stderr, "faulty_plant: --box takes empty, inverted, infinite, nan or mismatched\n");
        exit(2);
    }
    if (pl_encode_hello(w, "cart-on-rail", agents, f->agents) != PL_OK) {
        return PL_TOO_LONG;
    }
    return pl_send_version(stdout, w, (uint16_t)f->version);
}

/* The cart's answer, framed under the requested version. */
static pl_status send_reply(const faults *f, const cart_reply *r, pl_writer *w)
{
    pl_step step;
    if (f->version == PL_VERSION) {
        return cart_send(r, stdout);
    }
    if (r->error[0] != '\0') {
        pl_encode_error(w, r->error);
    } else if (r->answer == PL_RESET) {
        pl_encode_reset(w, r->observation, r->observation_len);
    } else {
        memset(&step, 0, sizeof step);
        step.observation_len = r->observation_len;
        step.observation = r->observation;
        step.reward = r->reward;
        step.success = PL_SUCCESS_NONE;
        pl_encode_step(w, &step);
    }
    return pl_send_version(stdout, w, (uint16_t)f->version);
}

/* Step n's fault, if it has one: 1 when the answer was sent (or never will be). */
static int misbehave(const faults *f, unsigned n, cart_reply *r)
{
    if (n == f->exit_at) {
        exit(3);
    }
    if (n == f->hang_at) {
        for (;;) {
            sleep(1000);
        }
    }
    if (n == f->garbage_at) {
        /* Text and a delimiter: the host reads a frame at once and finds it is not one (a
         * plant that prints its log to standard output by mistake). */
        static const char garbage[] = "step done, x = 0.25\n";
        fwrite(garbage, 1, sizeof garbage, stdout); /* sizeof: the '\0' goes too */
        fflush(stdout);
        return 1;
    }
    if (n == f->error_at) {
        snprintf(r->error, sizeof r->error, "the cart's motor driver tripped");
    }
    if (n == f->wrong_size_at) {
        r->observation_len = 2;
    }
    if (n == f->nan_at) {
        r->observation[0] = NAN;
    }
    if (n == f->inf_reward_at) {
        r->reward = INFINITY;
    }
    return 0;
}

int main(int argc, char **argv)
{
    faults f = parse(argc, argv);
    cart c = {0.0f, 0.0f, 0.0f, 0, 0, 0};
    pl_request req;
    cart_reply reply;
    pl_writer w;
    if (f.exit_at_start) {
        return 3;
    }
    for (;;) {
        pl_status s = pl_read_request(stdin, &req);
        if (s == PL_EOF) {
            return 0;
        }
        if (s != PL_OK) {
            s = cart_refuse(s, stdout);
        } else if (req.kind == PL_CLOSE) {
            if (!f.ignore_close) {
                return 0;
            }
        } else if (req.kind == PL_HELLO) {
            s = send_hello(&f, &w);
        } else {
            cart_answer(&c, &req, &reply);
            /* c.steps already counts this step once cart_answer has run it. */
            if (req.kind == PL_STEP && misbehave(&f, c.steps, &reply)) {
                continue;
            }
            s = send_reply(&f, &reply, &w);
        }
        if (s != PL_OK) {
            return 1;
        }
    }
}
