/* Lines over ARM semihosting, built by hand as firmware/src/console.rs builds them (text,
   hex f32 bits, decimals), and the two ways the firmware ends. */
#ifndef CONSOLE_H
#define CONSOLE_H

#include <stdint.h>

/* One output line of at most 256 bytes; longer text is cut (the newline is always kept). */
typedef struct {
    char buf[256];
    uint32_t len;
} line;

void line_new(line *l, const char *tag);
void line_push(line *l, const char *text);
/* " " and eight hex digits (how f32 bits are printed). */
void line_hex(line *l, uint32_t value);
/* " " and a decimal. */
void line_dec(line *l, uint32_t value);
/* Writes the line and a newline to the host's stdout. */
void line_emit(line *l);

/* Ends the run: QEMU exits with status 0, or 1 after a failure. */
void exit_ok(void) __attribute__((noreturn));
void exit_failure(void) __attribute__((noreturn));
/* Prints "FAIL <what>" and ends the run with status 1. */
void fail(const char *what) __attribute__((noreturn));

#endif
