/* Reset and exception entry of the example C firmware: the vector table, copying .data and
   zeroing .bss, the FPU switched on (Cortex-M4F), then main. Any fault or unexpected interrupt
   prints a FAIL line and ends the run, as the Rust firmware's handlers do. The same code serves
   the Cortex-M0 (ARMv6-M, Thumb-1, no FPU): it uses no instruction beyond Thumb-1 and no
   register the M0 lacks. */
#include <stdint.h>

#include "console.h"

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _stack_top;
int main(void);

void reset_handler(void) {
    uint32_t *src = &_sidata;
    for (uint32_t *dst = &_sdata; dst < &_edata;) {
        *dst++ = *src++;
    }
    for (uint32_t *dst = &_sbss; dst < &_ebss;) {
        *dst++ = 0;
    }
#if defined(__ARM_FP)
    /* CPACR: full access to CP10 and CP11 (the FPU) before any float instruction runs. */
    *(volatile uint32_t *)0xE000ED88 |= 0xFu << 20;
    __asm__ volatile("dsb\n\tisb" ::: "memory");
#endif
    main();
    exit_failure();
}

static void hard_fault_handler(void) {
    fail("HardFault");
}

static void default_handler(void) {
    fail("unexpected exception or interrupt");
}

/* 16 system exceptions and 32 device interrupts (the mps2 boards' first ones; all of the
   nRF51's). On the Cortex-M0 the MemManage, BusFault, UsageFault and DebugMonitor entries are
   reserved: never taken, every fault there is a HardFault. */
__attribute__((section(".vector_table"), used)) static void (*const vector_table[48])(void) = {
    (void (*)(void))(uintptr_t)&_stack_top,
    reset_handler,
    default_handler,    /* NMI */
    hard_fault_handler, /* HardFault */
    default_handler,    /* MemManage */
    default_handler,    /* BusFault */
    default_handler,    /* UsageFault */
    0, 0, 0, 0,
    default_handler, /* SVCall */
    default_handler, /* DebugMonitor */
    0,
    default_handler, /* PendSV */
    default_handler, /* SysTick */
    [16 ... 47] = default_handler,
};
