// Reset and fault vectors for the mps3-an547 (Cortex-M55 running Cortex-M33 code).
#include <stdint.h>
#include <string.h>
#include "semihost.h"

extern uint32_t _sbss, _ebss, _estack;
extern int main(void);

#define SCB_CPACR   (*(volatile uint32_t *)0xE000ED88)

__attribute__((noreturn)) void Reset_Handler(void) {
    // Single-precision FPU on (CP10, CP11 full access), as on the RP2350.
    SCB_CPACR |= (0xfu << 20);
    __asm__ volatile ("dsb\n isb" ::: "memory");
    memset(&_sbss, 0, (char *)&_ebss - (char *)&_sbss);
    sh_exit(main());
}

static void fault(const char *what) {
    sh_write0("FATAL: ");
    sh_write0(what);
    sh_write0("\n");
    sh_exit(134);
}

void NMI_Handler(void) { fault("NMI"); }
void HardFault_Handler(void) { fault("HardFault"); }
void MemManage_Handler(void) { fault("MemManage"); }
void BusFault_Handler(void) { fault("BusFault"); }
void UsageFault_Handler(void) { fault("UsageFault"); }
void SecureFault_Handler(void) { fault("SecureFault"); }
void Default_Handler(void) { fault("unexpected exception"); }

__attribute__((section(".isr_vector"), used))
const void *const isr_vector[16] = {
    &_estack,
    Reset_Handler,
    NMI_Handler,
    HardFault_Handler,
    MemManage_Handler,
    BusFault_Handler,
    UsageFault_Handler,
    SecureFault_Handler,
    0, 0, 0,
    Default_Handler,    // SVCall
    Default_Handler,    // DebugMonitor
    0,
    Default_Handler,    // PendSV
    Default_Handler,    // SysTick
};
