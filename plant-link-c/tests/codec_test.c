/*
 * codec_test.c: the codec against golden bytes, the frames of the exchange that
 * docs/own-plant.md shows byte by byte (as firmware-sim's Rust side writes them), and its
 * refusals. `make check` runs it under AddressSanitizer and UBSan; it prints the failures and
 * exits 1 if there are any.
 */
#include "plant_link.h"

#include <string.h>

static int failures = 0;

#define CHECK(cond)                                                        \
    do {                                                                   \
        if (!(cond)) {                                                     \
            fprintf(stderr, "%s:%d: failed: %s\n", __FILE__, __LINE__, #cond); \
            failures++;                                                    \
        }                                                                  \
    } while (0)

static float from_bits(uint32_t bits)
{
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
}

static uint32_t to_bits(float f)
{
    uint32_t bits;
    memcpy(&bits, &f, sizeof bits);
    return bits;
}

/* Decodes a frame given with its delimiter as a request. */
static pl_status request_of(const uint8_t *frame, size_t len, pl_request *req)
{
    uint8_t buf[PL_MAX_FRAME];
    const uint8_t *body;
    size_t body_len;
    uint16_t version;
    pl_status s;
    memcpy(buf, frame, len);
    s = pl_unframe(buf, len - 1, &version, &body, &body_len);
    if (s != PL_OK) {
        return s;
    }
    if (version != PL_VERSION) {
        return PL_VERSION_MISMATCH;
    }
    return pl_decode_request(body, body_len, req);
}

static void test_crc(void)
{
    CHECK(pl_crc32((const uint8_t *)"123456789", 9) == 0xCBF43926u);
    CHECK(pl_crc32(NULL, 0) == 0);
}

static void test_cobs(void)
{
    uint8_t in[300], out[310], back[310];
    size_t n, m;
    memset(in, 7, sizeof in);
    /* 254 bytes without a zero: one full block, and no empty block after it (as postcard). */
    n = pl_cobs_encode(in, 254, out, sizeof out);
    CHECK(n == 255 && out[0] == 0xFF);
    /* 255: a full block, then a block of one. */
    n = pl_cobs_encode(in, 255, out, sizeof out);
    CHECK(n == 257 && out[0] == 0xFF && out[255] == 0x02);
    memcpy(back, out, n);
    CHECK(pl_cobs_decode(back, n, &m) == PL_OK && m == 255 && memcmp(back, in, 255) == 0);
    in[0] = 0;
    n = pl_cobs_encode(in, 1, out, sizeof out);
    CHECK(n == 2 && out[0] == 1 && out[1] == 1);
    CHECK(pl_cobs_encode(in, 255, out, 100) == 0); /* does not fit */
    out[0] = 9; /* a block longer than the frame */
    CHECK(pl_cobs_decode(out, 2, &m) == PL_COBS);
}

static void test_golden_requests(void)
{
    static const uint8_t hello[] = {0x03, 0x01, 0x01, 0x05, 0x64, 0x82, 0x98, 0xe7, 0x00};
    static const uint8_t reset[] = {0x09, 0x01, 0x02, 0x01, 0x01, 0xc0, 0x6d, 0x60, 0xf4, 0x00};
    static const uint8_t step[] = {0x05, 0x01, 0x0a, 0x02, 0x02, 0x01, 0x01, 0x0a, 0xbf,
                                   0x9a, 0x99, 0x19, 0xbf, 0x40, 0x30, 0xaa, 0x5a, 0x00};
    uint8_t out[64];
    size_t n;
    pl_request req;
    const uint8_t hello_body[] = {0x00};
    /* The codec frames as the host does, byte for byte. */
    CHECK(pl_frame(hello_body, 1, PL_VERSION, out, sizeof out, &n) == PL_OK);
    CHECK(n == sizeof hello && memcmp(out, hello, n) == 0);
    CHECK(request_of(hello, sizeof hello, &req) == PL_OK && req.kind == PL_HELLO);
    CHECK(request_of(reset, sizeof reset, &req) == PL_OK && req.kind == PL_RESET && req.seed == 1);
    CHECK(request_of(step, sizeof step, &req) == PL_OK && req.kind == PL_STEP);
    CHECK(req.action_len == 2 && req.action[0] == -0.5f && to_bits(req.action[1]) == 0xbf19999au);
}

static void test_golden_answer(void)
{
    static const uint8_t reset[] = {0x09, 0x01, 0x0a, 0x01, 0x02, 0x86, 0x8a, 0x8f, 0xbf, 0x01,
                                    0x07, 0xb8, 0xc0, 0x15, 0x77, 0xd0, 0xb0, 0x00};
    float observation[2];
    pl_writer w;
    uint8_t out[64];
    size_t n;
    observation[0] = from_bits(0xbf8f8a86u);
    observation[1] = -5.75f;
    CHECK(pl_encode_reset(&w, observation, 2) == PL_OK);
    CHECK(pl_frame(w.data, w.len, PL_VERSION, out, sizeof out, &n) == PL_OK);
    CHECK(n == sizeof reset && memcmp(out, reset, n) == 0);
}

static void test_refusals(void)
{
    static const uint8_t hello[] = {0x03, 0x01, 0x01, 0x05, 0x64, 0x82, 0x98, 0xe7, 0x00};
    uint8_t frame[32], out[PL_MAX_FRAME];
    uint8_t body[8 + 4 * 65];
    size_t n, bit;
    pl_request req;
    pl_writer w;
    float many[PL_MAX_VALUES + 1];
    /* Every single bit flipped: refused. */
    for (bit = 0; bit < 8 * (sizeof hello - 1); bit++) {
        memcpy(frame, hello, sizeof hello);
        frame[bit / 8] ^= (uint8_t)(1u << (bit % 8));
        CHECK(request_of(frame, sizeof hello, &req) != PL_OK);
    }
    /* Another version, named as such. */
    body[0] = 0;
    CHECK(pl_frame(body, 1, 2, out, sizeof out, &n) == PL_OK);
    CHECK(request_of(out, n, &req) == PL_VERSION_MISMATCH);
    /* A message that does not fill its body, an unknown variant, a varint too long. */
    body[0] = 0;
    body[1] = 0;
    CHECK(pl_frame(body, 2, PL_VERSION, out, sizeof out, &n) == PL_OK);
    CHECK(request_of(out, n, &req) == PL_MALFORMED);
    body[0] = 4;
    CHECK(pl_frame(body, 1, PL_VERSION, out, sizeof out, &n) == PL_OK);
    CHECK(request_of(out, n, &req) == PL_MALFORMED);
    memset(body, 0xFF, 11);
    body[0] = 1;
    body[11] = 0x01;
    CHECK(pl_frame(body, 12, PL_VERSION, out, sizeof out, &n) == PL_OK);
    CHECK(request_of(out, n, &req) == PL_MALFORMED);
    /* Over the caps: refused with their own status, nothing written past a buffer. */
    memset(many, 0, sizeof many);
    CHECK(pl_encode_reset(&w, many, PL_MAX_VALUES + 1) == PL_TOO_MANY_VALUES);
    CHECK(pl_encode_reset(&w, many, PL_MAX_VALUES) == PL_OK);
    pl_writer_init(&w);
    pl_put_varint(&w, 2);
    pl_put_f32s(&w, many, PL_MAX_VALUES + 1);
    CHECK(pl_frame(w.data, w.len, PL_VERSION, out, sizeof out, &n) == PL_OK);
    CHECK(request_of(out, n, &req) == PL_TOO_MANY_VALUES);
    CHECK(pl_frame(w.data, w.len, PL_VERSION, out, 40, &n) == PL_TOO_LONG);
}

static void test_read_frame(void)
{
    FILE *f = tmpfile();
    uint8_t buf[16];
    size_t n, i;
    if (f == NULL) {
        CHECK(f != NULL);
        return;
    }
    /* An empty frame, a frame too long for the buffer, a good one, half a frame. */
    fputc(0, f);
    for (i = 0; i < 40; i++) {
        fputc('x', f);
    }
    fputc(0, f);
    fputs("abc", f);
    fputc(0, f);
    fputs("de", f);
    rewind(f);
    CHECK(pl_read_frame(f, buf, sizeof buf, &n) == PL_TOO_LONG);
    CHECK(pl_read_frame(f, buf, sizeof buf, &n) == PL_OK && n == 3 && memcmp(buf, "abc", 3) == 0);
    CHECK(pl_read_frame(f, buf, sizeof buf, &n) == PL_EOF);
    fclose(f);
}

int main(void)
{
    test_crc();
    test_cobs();
    test_golden_requests();
    test_golden_answer();
    test_refusals();
    test_read_frame();
    if (failures != 0) {
        fprintf(stderr, "codec_test: %d failures\n", failures);
        return 1;
    }
    printf("codec_test: all passed\n");
    return 0;
}
