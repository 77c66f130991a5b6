/* The <string.h> CMSIS-NN includes, for a toolchain without a C library (Debian's
   gcc-arm-none-eabi, as scripts/cortex-m.sh installs it: the example firmware links none). The
   functions come from compiler-builtins, linked through policy-core-ffi; GCC expands the small
   fixed-size calls (CMSIS-NN's 4-byte reads) inline as it would with a C library's header. */
#ifndef CMSIS_NN_BENCH_STRING_H
#define CMSIS_NN_BENCH_STRING_H

#include <stddef.h>

void *memcpy(void *restrict dst, const void *restrict src, size_t n);
void *memmove(void *dst, const void *src, size_t n);
void *memset(void *dst, int c, size_t n);
int memcmp(const void *a, const void *b, size_t n);

#endif
