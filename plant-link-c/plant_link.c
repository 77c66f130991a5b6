/*
 * plant_link.c: the plant link's codec (see plant_link.h and README.md).
 *
 * The decoder follows postcard's and hil-protocol's rules exactly, so a frame the host would
 * refuse is refused here too: varints within their type's bytes and range, bools 0 or 1, the
 * message filling its body, the CRC over the envelope.
 */
#include "plant_link.h"

#include <string.h>

const char *pl_status_text(pl_status status)
{
    switch (status) {
    case PL_OK: return "ok";
    case PL_EOF: return "the input ended";
    case PL_IO: return "a read or write failed";
    case PL_TOO_LONG: return "a frame longer than PL_MAX_FRAME (4096) bytes";
    case PL_TOO_MANY_VALUES: return "a list of more than PL_MAX_VALUES (64) values";
    case PL_COBS: return "a garbled frame (invalid COBS)";
    case PL_CRC: return "a garbled frame (CRC-32 mismatch)";
    case PL_TRUNCATED: return "a truncated frame";
    case PL_VERSION_MISMATCH: return "a frame of another plant protocol version; this side speaks version 1";
    case PL_MALFORMED: return "a frame holding no request of plant protocol version 1";
    }
    return "an unknown status";
}

/* ---- CRC-32/ISO-HDLC, bitwise: a table would cost 1 KiB for speed a plant does not need. ---- */

uint32_t pl_crc32(const uint8_t *data, size_t len)
{
    uint32_t crc = 0xFFFFFFFFu;
    size_t i;
    int bit;
    for (i = 0; i < len; i++) {
        crc ^= data[i];
        for (bit = 0; bit < 8; bit++) {
            crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
        }
    }
    return ~crc;
}

/* ---- COBS ---- */

size_t pl_cobs_encode(const uint8_t *in, size_t len, uint8_t *out, size_t cap)
{
    size_t code_at = 0, o = 1, i;
    uint8_t code = 1;
    if (cap == 0) {
        return 0;
    }
    for (i = 0; i < len; i++) {
        if (in[i] == 0) {
            out[code_at] = code;
            code = 1;
            code_at = o++;
            if (o > cap) {
                return 0;
            }
            continue;
        }
        if (o >= cap) {
            return 0;
        }
        out[o++] = in[i];
        code++;
        /* A full block of 254 data bytes has no implied zero; the next block starts here,
         * unless the data ends (postcard's COBS writes no empty block after a full one). */
        if (code == 0xFF && i + 1 < len) {
            out[code_at] = code;
            code = 1;
            code_at = o++;
            if (o > cap) {
                return 0;
            }
        }
    }
    out[code_at] = code;
    return o;
}

pl_status pl_cobs_decode(uint8_t *buf, size_t len, size_t *out_len)
{
    size_t src = 0, dst = 0, k;
    if (len == 0) {
        return PL_COBS;
    }
    while (src < len) {
        uint8_t code = buf[src];
        if (code == 0 || (src + code > len && code != 1)) {
            return PL_COBS;
        }
        src++;
        for (k = 1; k < code; k++) {
            buf[dst++] = buf[src++];
        }
        if (code != 0xFF && src < len) {
            buf[dst++] = 0;
        }
    }
    *out_len = dst;
    return PL_OK;
}

/* ---- Writing postcard ---- */

void pl_writer_init(pl_writer *w)
{
    w->len = 0;
    w->overflow = 0;
}

static void put_byte(pl_writer *w, uint8_t b)
{
    if (w->overflow || w->len >= sizeof w->data) {
        w->overflow = 1;
        return;
    }
    w->data[w->len++] = b;
}

void pl_put_varint(pl_writer *w, uint64_t value)
{
    while (value >= 0x80u) {
        put_byte(w, (uint8_t)(value | 0x80u));
        value >>= 7;
    }
    put_byte(w, (uint8_t)value);
}

void pl_put_f32(pl_writer *w, float value)
{
    uint32_t bits;
    int i;
    /* memcpy keeps every bit, NaN payloads included; postcard writes them little-endian. */
    memcpy(&bits, &value, sizeof bits);
    for (i = 0; i < 4; i++) {
        put_byte(w, (uint8_t)(bits >> (8 * i)));
    }
}

void pl_put_bool(pl_writer *w, int value)
{
    put_byte(w, value ? 1u : 0u);
}

void pl_put_str(pl_writer *w, const char *text)
{
    size_t n = strlen(text), i;
    pl_put_varint(w, n);
    for (i = 0; i < n; i++) {
        put_byte(w, (uint8_t)text[i]);
    }
}

void pl_put_f32s(pl_writer *w, const float *values, size_t n)
{
    size_t i;
    pl_put_varint(w, n);
    for (i = 0; i < n; i++) {
        pl_put_f32(w, values[i]);
    }
}

/* ---- Reading postcard ---- */

pl_status pl_get_varint(pl_reader *r, uint64_t *value, unsigned max_bytes, uint64_t max)
{
    uint64_t out = 0;
    unsigned i;
    for (i = 0; i < max_bytes; i++) {
        uint8_t b;
        if (r->pos >= r->len) {
            return PL_TRUNCATED;
        }
        b = r->data[r->pos++];
        /* Bits beyond 64 in the tenth byte of a u64 would be lost: refused, as postcard does. */
        if (i == 9 && (b & 0x7Fu) > 1u) {
            return PL_MALFORMED;
        }
        out |= (uint64_t)(b & 0x7Fu) << (7 * i);
        if ((b & 0x80u) == 0) {
            if (out > max) {
                return PL_MALFORMED;
            }
            *value = out;
            return PL_OK;
        }
    }
    return PL_MALFORMED;
}

pl_status pl_get_f32(pl_reader *r, float *value)
{
    uint32_t bits = 0;
    int i;
    if (r->len - r->pos < 4) {
        return PL_TRUNCATED;
    }
    for (i = 0; i < 4; i++) {
        bits |= (uint32_t)r->data[r->pos++] << (8 * i);
    }
    memcpy(value, &bits, sizeof bits);
    return PL_OK;
}

pl_status pl_get_f32s(pl_reader *r, float *values, uint32_t *n)
{
    uint64_t len;
    uint32_t i;
    pl_status s = pl_get_varint(r, &len, 10, UINT64_MAX);
    if (s != PL_OK) {
        return s;
    }
    if (len > PL_MAX_VALUES) {
        return PL_TOO_MANY_VALUES;
    }
    for (i = 0; i < (uint32_t)len; i++) {
        s = pl_get_f32(r, &values[i]);
        if (s != PL_OK) {
            return s;
        }
    }
    *n = (uint32_t)len;
    return PL_OK;
}

/* ---- Frames ---- */

pl_status pl_read_frame(FILE *in, uint8_t *buf, size_t cap, size_t *len)
{
    size_t n = 0;
    int too_long = 0, c;
    for (;;) {
        c = getc(in);
        if (c == EOF) {
            return ferror(in) ? PL_IO : PL_EOF;
        }
        if (c != 0) {
            /* The delimiter is one of the cap bytes: a frame fills at most cap - 1. */
            if (n + 1 < cap) {
                buf[n++] = (uint8_t)c;
            } else {
                too_long = 1;
            }
            continue;
        }
        if (too_long) {
            return PL_TOO_LONG;
        }
        if (n > 0) {
            *len = n;
            return PL_OK;
        }
    }
}

pl_status pl_unframe(uint8_t *buf, size_t len, uint16_t *version, const uint8_t **body,
                     size_t *body_len)
{
    size_t n;
    uint64_t v, blen;
    uint32_t crc;
    pl_reader r;
    pl_status s = pl_cobs_decode(buf, len, &n);
    if (s != PL_OK) {
        return s;
    }
    r.data = buf;
    r.len = n;
    r.pos = 0;
    /* The envelope first: the CRC sits after it, so its length is known only once read. */
    if ((s = pl_get_varint(&r, &v, 3, 0xFFFFu)) != PL_OK ||
        (s = pl_get_varint(&r, &blen, 10, UINT64_MAX)) != PL_OK) {
        return s == PL_TRUNCATED ? PL_TRUNCATED : PL_CRC;
    }
    if (blen > n - r.pos || n - r.pos - (size_t)blen < 4) {
        return PL_TRUNCATED;
    }
    *body = buf + r.pos;
    *body_len = (size_t)blen;
    r.pos += (size_t)blen;
    crc = (uint32_t)buf[r.pos] | (uint32_t)buf[r.pos + 1] << 8 | (uint32_t)buf[r.pos + 2] << 16 |
          (uint32_t)buf[r.pos + 3] << 24;
    /* Bytes after the CRC are refused, as the host refuses them: the CRC ends the frame. */
    if (crc != pl_crc32(buf, r.pos) || r.pos + 4 != n) {
        return PL_CRC;
    }
    *version = (uint16_t)v;
    return PL_OK;
}

pl_status pl_frame(const uint8_t *body, size_t body_len, uint16_t version, uint8_t *out,
                   size_t cap, size_t *out_len)
{
    pl_writer env;
    uint32_t crc;
    size_t i, n;
    pl_writer_init(&env);
    pl_put_varint(&env, version);
    pl_put_varint(&env, body_len);
    for (i = 0; i < body_len; i++) {
        put_byte(&env, body[i]);
    }
    crc = pl_crc32(env.data, env.len);
    for (i = 0; i < 4; i++) {
        put_byte(&env, (uint8_t)(crc >> (8 * i)));
    }
    if (env.overflow || cap < 2) {
        return PL_TOO_LONG;
    }
    n = pl_cobs_encode(env.data, env.len, out, cap - 1);
    if (n == 0) {
        return PL_TOO_LONG;
    }
    out[n] = 0;
    *out_len = n + 1;
    return PL_OK;
}

pl_status pl_send_version(FILE *out, const pl_writer *w, uint16_t version)
{
    uint8_t frame[PL_MAX_FRAME];
    size_t n;
    pl_status s;
    if (w->overflow) {
        return PL_TOO_LONG;
    }
    s = pl_frame(w->data, w->len, version, frame, sizeof frame, &n);
    if (s != PL_OK) {
        return s;
    }
    if (fwrite(frame, 1, n, out) != n || fflush(out) != 0) {
        return PL_IO;
    }
    return PL_OK;
}

pl_status pl_send(FILE *out, const pl_writer *w)
{
    return pl_send_version(out, w, PL_VERSION);
}

/* ---- Requests ---- */

pl_status pl_decode_request(const uint8_t *body, size_t len, pl_request *request)
{
    pl_reader r;
    uint64_t variant;
    pl_status s;
    r.data = body;
    r.len = len;
    r.pos = 0;
    if ((s = pl_get_varint(&r, &variant, 5, 0xFFFFFFFFu)) != PL_OK) {
        return s;
    }
    switch (variant) {
    case PL_HELLO:
    case PL_CLOSE:
        break;
    case PL_RESET:
        s = pl_get_varint(&r, &request->seed, 10, UINT64_MAX);
        break;
    case PL_STEP:
        s = pl_get_f32s(&r, request->action, &request->action_len);
        break;
    default:
        return PL_MALFORMED;
    }
    if (s != PL_OK) {
        return s == PL_TOO_MANY_VALUES ? s : PL_MALFORMED;
    }
    /* The message must fill the body: a shorter reading is another message misread. */
    if (r.pos != r.len) {
        return PL_MALFORMED;
    }
    request->kind = (pl_request_kind)variant;
    return PL_OK;
}

pl_status pl_read_request(FILE *in, pl_request *request)
{
    uint8_t buf[PL_MAX_FRAME];
    size_t n, body_len;
    uint16_t version;
    const uint8_t *body;
    pl_status s = pl_read_frame(in, buf, sizeof buf, &n);
    if (s != PL_OK) {
        return s;
    }
    if ((s = pl_unframe(buf, n, &version, &body, &body_len)) != PL_OK) {
        return s;
    }
    if (version != PL_VERSION) {
        return PL_VERSION_MISMATCH;
    }
    return pl_decode_request(body, body_len, request);
}

/* ---- Answers ---- */

static pl_status finish(const pl_writer *w)
{
    return w->overflow ? PL_TOO_LONG : PL_OK;
}

static pl_status put_values(pl_writer *w, const float *values, uint32_t n)
{
    if (n > PL_MAX_VALUES) {
        return PL_TOO_MANY_VALUES;
    }
    pl_put_f32s(w, values, n);
    return PL_OK;
}

pl_status pl_encode_hello(pl_writer *w, const char *name, const pl_agent *agents, size_t n_agents)
{
    size_t i;
    pl_writer_init(w);
    pl_put_varint(w, 0); /* FromPlant::Hello */
    pl_put_str(w, name);
    pl_put_varint(w, n_agents);
    for (i = 0; i < n_agents; i++) {
        const pl_agent *a = &agents[i];
        pl_put_str(w, a->name);
        if (put_values(w, a->observation_low, a->observation_len) != PL_OK ||
            put_values(w, a->observation_high, a->observation_len) != PL_OK ||
            put_values(w, a->action_low, a->action_len) != PL_OK ||
            put_values(w, a->action_high, a->action_len) != PL_OK) {
            return PL_TOO_MANY_VALUES;
        }
    }
    return finish(w);
}

pl_status pl_encode_reset(pl_writer *w, const float *observation, uint32_t n)
{
    pl_writer_init(w);
    pl_put_varint(w, 1); /* FromPlant::Reset */
    if (put_values(w, observation, n) != PL_OK) {
        return PL_TOO_MANY_VALUES;
    }
    return finish(w);
}

pl_status pl_encode_step(pl_writer *w, const pl_step *step)
{
    pl_writer_init(w);
    pl_put_varint(w, 2); /* FromPlant::Step */
    if (put_values(w, step->observation, step->observation_len) != PL_OK) {
        return PL_TOO_MANY_VALUES;
    }
    pl_put_f32(w, step->reward);
    pl_put_bool(w, step->terminated);
    pl_put_bool(w, step->truncated);
    pl_put_bool(w, step->margin_touched);
    if (put_values(w, step->applied, step->applied_len) != PL_OK) {
        return PL_TOO_MANY_VALUES;
    }
    if (step->success == PL_SUCCESS_NONE) {
        pl_put_varint(w, 0);
    } else {
        pl_put_varint(w, 1);
        pl_put_bool(w, step->success);
    }
    return finish(w);
}

pl_status pl_encode_error(pl_writer *w, const char *message)
{
    pl_writer_init(w);
    pl_put_varint(w, 3); /* FromPlant::Error */
    pl_put_str(w, message);
    return finish(w);
}

/* Each send holds its writer on the stack (about 4 KiB, with 8 KiB more while framing): no
 * static state, so a plant may serve several links from several threads. */
static pl_status send_encoded(FILE *out, const pl_writer *w, pl_status encoded)
{
    return encoded != PL_OK ? encoded : pl_send(out, w);
}

pl_status pl_send_hello(FILE *out, const char *name, const pl_agent *agents, size_t n_agents)
{
    pl_writer w;
    pl_status s = pl_encode_hello(&w, name, agents, n_agents);
    return send_encoded(out, &w, s);
}

pl_status pl_send_reset(FILE *out, const float *observation, uint32_t n)
{
    pl_writer w;
    pl_status s = pl_encode_reset(&w, observation, n);
    return send_encoded(out, &w, s);
}

pl_status pl_send_step(FILE *out, const pl_step *step)
{
    pl_writer w;
    pl_status s = pl_encode_step(&w, step);
    return send_encoded(out, &w, s);
}

pl_status pl_send_error(FILE *out, const char *message)
{
    pl_writer w;
    pl_status s = pl_encode_error(&w, message);
    return send_encoded(out, &w, s);
}
