/*
 * plant_link.h: the plant side of the plant link in C99, for a plant that runs as a child
 * process of the trainer (host-trainer train --plant-cmd) or of the closed-loop checker
 * (firmware-sim run --plant-cmd) and speaks on its standard input and output.
 *
 * Everything the plant needs and nothing else: CRC-32, COBS, postcard's varints and f32s,
 * reading one frame from a FILE* under a size limit, decoding the host's four requests and
 * encoding the plant's four answers. No malloc: every size is a fixed cap below, and a message
 * over a cap is refused with its own status rather than cut. README.md has the wire format.
 */
#ifndef PLANT_LINK_H
#define PLANT_LINK_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The plant protocol version every frame carries (firmware-sim's messages::VERSION). */
#define PL_VERSION 1u
/* The most values in one observation, action or box side this codec handles. */
#define PL_MAX_VALUES 64u
/* The longest frame read or written, delimiter included. The host accepts up to 1 MiB; a C
 * plant sizes its buffers for what it sends: a hello with 64-value boxes is about 1,100 bytes. */
#define PL_MAX_FRAME 4096u
/* The most bytes of a message's postcard body: the frame less its envelope (version 3 bytes,
 * length 2, CRC 4), COBS's overhead (1 byte in 254, plus 1) and the delimiter. */
#define PL_MAX_BODY (PL_MAX_FRAME - 9u - (PL_MAX_FRAME / 254u + 1u) - 1u)

/* What went wrong; PL_OK is 0. pl_status_text says it in words. */
typedef enum {
    PL_OK = 0,
    PL_EOF,             /* the input ended (the host is gone: exit) */
    PL_IO,              /* reading or writing failed */
    PL_TOO_LONG,        /* a frame over PL_MAX_FRAME, or a body over PL_MAX_BODY */
    PL_TOO_MANY_VALUES, /* a list of more than PL_MAX_VALUES values */
    PL_COBS,            /* the frame's COBS is invalid */
    PL_CRC,             /* the CRC-32 does not match */
    PL_TRUNCATED,       /* the frame or message ends early */
    PL_VERSION_MISMATCH, /* a frame of another protocol version */
    PL_MALFORMED        /* an intact frame holding no request of this version */
} pl_status;

/* One line saying what the status means (static text). */
const char *pl_status_text(pl_status status);

/* ---- The building blocks ---- */

/* CRC-32/ISO-HDLC (zlib's): of "123456789" it is 0xCBF43926. */
uint32_t pl_crc32(const uint8_t *data, size_t len);

/* COBS-encodes len bytes into out (no delimiter added); the encoded length, or 0 if it does not
 * fit in cap (an encoding is never empty). */
size_t pl_cobs_encode(const uint8_t *in, size_t len, uint8_t *out, size_t cap);

/* COBS-decodes the bytes before a delimiter, in place; the decoded length in *out_len. */
pl_status pl_cobs_decode(uint8_t *buf, size_t len, size_t *out_len);

/* A message body being written: put calls append; one that does not fit sets overflow and
 * writes nothing more, so a sequence of puts is checked once at the end. */
typedef struct {
    uint8_t data[PL_MAX_BODY];
    size_t len;
    int overflow;
} pl_writer;

void pl_writer_init(pl_writer *w);
void pl_put_varint(pl_writer *w, uint64_t value);
void pl_put_f32(pl_writer *w, float value);
void pl_put_bool(pl_writer *w, int value);
/* A postcard string: the length as a varint, then the bytes (give UTF-8). */
void pl_put_str(pl_writer *w, const char *text);
/* A postcard Vec<f32>: the length, then the values. */
void pl_put_f32s(pl_writer *w, const float *values, size_t n);

/* A message body being read: get calls return PL_OK or why not, and never read past len. */
typedef struct {
    const uint8_t *data;
    size_t len;
    size_t pos;
} pl_reader;

/* An unsigned LEB128 varint of at most max_bytes bytes whose value is at most max (postcard's
 * rules: 3 bytes for a u16, 5 for a u32, 10 for a u64). */
pl_status pl_get_varint(pl_reader *r, uint64_t *value, unsigned max_bytes, uint64_t max);
pl_status pl_get_f32(pl_reader *r, float *value);
/* A Vec<f32> of at most PL_MAX_VALUES values. */
pl_status pl_get_f32s(pl_reader *r, float *values, uint32_t *n);

/* ---- Frames ---- */

/* Reads the bytes before the next 0x00 into buf (cap bytes, the delimiter counted); skips
 * empty frames. PL_EOF when the input ends, a half frame included; a frame longer than cap is
 * read to its delimiter and refused as PL_TOO_LONG, so the next frame is read whole. */
pl_status pl_read_frame(FILE *in, uint8_t *buf, size_t cap, size_t *len);

/* Undoes the framing of the bytes before a delimiter (in place): COBS, CRC, envelope. Gives the
 * version, whatever it is, and the body's place in buf. */
pl_status pl_unframe(uint8_t *buf, size_t len, uint16_t *version, const uint8_t **body,
                     size_t *body_len);

/* Frames a body under a version (the envelope, its CRC, COBS, the delimiter) into out. */
pl_status pl_frame(const uint8_t *body, size_t body_len, uint16_t version, uint8_t *out,
                   size_t cap, size_t *out_len);

/* Frames w's body under version, writes it and flushes (the host waits for each answer). */
pl_status pl_send_version(FILE *out, const pl_writer *w, uint16_t version);
/* pl_send_version under PL_VERSION. */
pl_status pl_send(FILE *out, const pl_writer *w);

/* ---- The host's requests ---- */

typedef enum { PL_HELLO = 0, PL_RESET = 1, PL_STEP = 2, PL_CLOSE = 3 } pl_request_kind;

/* The 64-bit seed first: no padding between the fields on common ABIs. */
typedef struct {
    uint64_t seed;                /* PL_RESET: the episode's seed */
    pl_request_kind kind;
    uint32_t action_len;          /* PL_STEP: the action's values */
    float action[PL_MAX_VALUES];
} pl_request;

/* Decodes a request body; refuses trailing bytes, as the host does. */
pl_status pl_decode_request(const uint8_t *body, size_t len, pl_request *request);

/* Reads the next frame from in and decodes it as a request of PL_VERSION. PL_EOF: exit. Any
 * other failure: answer with pl_send_error and read on. */
pl_status pl_read_request(FILE *in, pl_request *request);

/* ---- The plant's answers ---- */

/* One agent's name and boxes: low[i] <= x[i] <= high[i]. Observation bounds may be infinite;
 * action bounds must be finite with low < high. */
typedef struct {
    const char *name;
    const float *observation_low;
    const float *observation_high;
    const float *action_low;
    const float *action_high;
    uint32_t observation_len;
    uint32_t action_len;
} pl_agent;

/* What one action did. */
typedef struct {
    uint32_t observation_len;
    const float *observation;
    float reward;
    int terminated;     /* a terminal state */
    int truncated;      /* cut by a time limit */
    int margin_touched; /* a hard margin was touched */
    uint32_t applied_len; /* 0: the host takes the action as applied */
    const float *applied; /* the motion carried out, in action units */
    int success;        /* PL_SUCCESS_NONE, 0 or 1 */
} pl_step;

#define PL_SUCCESS_NONE (-1)

/* Each encodes one answer into w (initialising it): PL_TOO_MANY_VALUES for a list over
 * PL_MAX_VALUES, PL_TOO_LONG for a body over PL_MAX_BODY. Send it with pl_send. */
pl_status pl_encode_hello(pl_writer *w, const char *name, const pl_agent *agents, size_t n_agents);
pl_status pl_encode_reset(pl_writer *w, const float *observation, uint32_t n);
pl_status pl_encode_step(pl_writer *w, const pl_step *step);
pl_status pl_encode_error(pl_writer *w, const char *message);

/* Encode and send in one call. */
pl_status pl_send_hello(FILE *out, const char *name, const pl_agent *agents, size_t n_agents);
pl_status pl_send_reset(FILE *out, const float *observation, uint32_t n);
pl_status pl_send_step(FILE *out, const pl_step *step);
pl_status pl_send_error(FILE *out, const char *message);

#ifdef __cplusplus
}
#endif

#endif /* PLANT_LINK_H */
