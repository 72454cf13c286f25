/* Start-up for QEMU's mps2-an386 and the semihosting calls the PIL harness
 * uses (ARM semihosting: bkpt 0xAB, the operation in r0, its block in r1). */
#include <stdint.h>
#include <string.h>

extern uint32_t __bss_start__, __bss_end__, __stack_top;
int main(void);
void Reset_Handler(void);
void Default_Handler(void);

__attribute__((section(".vectors"), used))
static void (*const vectors[16])(void) = {
    (void (*)(void))&__stack_top, Reset_Handler,
    Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
};

int sh_call(int op, void *arg)
{
    register int r0 __asm__("r0") = op;
    register void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void sh_exit(int ok)
{
    /* SYS_EXIT with ADP_Stopped_ApplicationExit (QEMU exits 0) or RunTimeErrorUnknown (exits 1) */
    sh_call(0x18, (void *)(uintptr_t)(ok ? 0x20026 : 0x20023));
    for (;;) {
    }
}

void Default_Handler(void)
{
    static const char msg[] = "pil: fault exception\n";
    sh_call(0x04, (void *)msg);
    sh_exit(0);
}

void Reset_Handler(void)
{
    /* the FPU: full access for CP10 and CP11 (CPACR), before any float instruction */
    *(volatile uint32_t *)0xE000ED88u |= 0xFu << 20;
    __asm__ volatile("dsb\n isb");
    memset(&__bss_start__, 0, (size_t)((char *)&__bss_end__ - (char *)&__bss_start__));
    sh_exit(main() == 0);
}
