/* Semihosting output and exit, as cortex-m-semihosting does it for the Rust firmware: the
   host's stdout is the file ":tt" opened for writing, and SYS_EXIT ends QEMU. */
#include "console.h"

#define SYS_OPEN 0x01
#define SYS_WRITE 0x05
#define SYS_EXIT 0x18
/* SYS_EXIT reasons: QEMU exits with 0 for ApplicationExit, 1 for anything else. */
#define ADP_STOPPED_APPLICATION_EXIT 0x20026
#define ADP_STOPPED_RUNTIME_ERROR 0x20023

static int32_t semihost(uint32_t op, const void *arg) {
    register uint32_t r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return (int32_t)r0;
}

static int32_t stdout_handle = -1;

void line_new(line *l, const char *tag) {
    l->len = 0;
    line_push(l, tag);
}

void line_push(line *l, const char *text) {
    while (*text && l->len < sizeof l->buf) {
        l->buf[l->len++] = *text++;
    }
}

void line_hex(line *l, uint32_t value) {
    char digits[10];
    digits[0] = ' ';
    for (int i = 0; i < 8; i++) {
        digits[1 + i] = "0123456789abcdef"[(value >> (28 - 4 * i)) & 0xF];
    }
    digits[9] = 0;
    line_push(l, digits);
}

void line_dec(line *l, uint32_t value) {
    char digits[12];
    int at = 11;
    digits[at] = 0;
    do {
        digits[--at] = (char)('0' + value % 10);
        value /= 10;
    } while (value != 0);
    digits[--at] = ' ';
    line_push(l, &digits[at]);
}

void line_emit(line *l) {
    if (l->len > sizeof l->buf - 1) {
        l->len = sizeof l->buf - 1;
    }
    l->buf[l->len++] = '\n';
    if (stdout_handle < 0) {
        const uint32_t open[3] = {(uint32_t)(uintptr_t) ":tt", 4 /* "w" */, 3};
        stdout_handle = semihost(SYS_OPEN, open);
    }
    if (stdout_handle >= 0) {
        const uint32_t write[3] = {(uint32_t)stdout_handle, (uint32_t)(uintptr_t)l->buf, l->len};
        /* Nothing better to do if the host stops listening: the exit status still reports. */
        (void)semihost(SYS_WRITE, write);
    }
}

void exit_ok(void) {
    semihost(SYS_EXIT, (const void *)ADP_STOPPED_APPLICATION_EXIT);
    for (;;) {
        __asm__ volatile("wfi");
    }
}

void exit_failure(void) {
    semihost(SYS_EXIT, (const void *)ADP_STOPPED_RUNTIME_ERROR);
    for (;;) {
        __asm__ volatile("wfi");
    }
}

void fail(const char *what) {
    line l;
    line_new(&l, "FAIL ");
    line_push(&l, what);
    line_emit(&l);
    exit_failure();
}
