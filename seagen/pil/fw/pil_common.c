/* pil_common.c -- start-up (.data copy, .bss clear), vector table, RX queue, SysTick and semihosting. */
#include "pil_board.h"

extern uint32_t __data_load, __data_start, __data_end, __bss_start, __bss_end, __stack_top;
int main(void);
void pil_reset_handler(void);
void pil_fault_handler(void);
void pil_uart_irq(void);

void pil_reset_handler(void)
{
    const uint32_t *src = &__data_load;
    uint32_t *dst;
    for (dst = &__data_start; dst < &__data_end; ++dst) {
        *dst = *src++;
    }
    for (dst = &__bss_start; dst < &__bss_end; ++dst) {
        *dst = 0u;
    }
    pil_exit(main());
}

void pil_fault_handler(void)
{
    pil_puts("pil: hard fault\n");
    pil_exit(3);
}

static void pil_default_handler(void)
{
    pil_puts("pil: unexpected interrupt\n");
    pil_exit(4);
}

/* 16 system exceptions, then 32 external interrupts; the board's UART vector is PIL_UART_IRQ. */
typedef void (*pil_vector)(void);
#define PIL_V(n) ((n) == PIL_UART_IRQ ? pil_uart_irq : pil_default_handler)
__attribute__((section(".isr_vector"), used)) static const pil_vector pil_vectors[48] = {
    (pil_vector)(uintptr_t)&__stack_top, pil_reset_handler, pil_fault_handler, pil_fault_handler,
    pil_fault_handler, pil_fault_handler, pil_fault_handler, 0, 0, 0, 0, pil_default_handler,
    pil_default_handler, 0, pil_default_handler, pil_default_handler,
    PIL_V(0), PIL_V(1), PIL_V(2), PIL_V(3), PIL_V(4), PIL_V(5), PIL_V(6), PIL_V(7),
    PIL_V(8), PIL_V(9), PIL_V(10), PIL_V(11), PIL_V(12), PIL_V(13), PIL_V(14), PIL_V(15),
    PIL_V(16), PIL_V(17), PIL_V(18), PIL_V(19), PIL_V(20), PIL_V(21), PIL_V(22), PIL_V(23),
    PIL_V(24), PIL_V(25), PIL_V(26), PIL_V(27), PIL_V(28), PIL_V(29), PIL_V(30), PIL_V(31),
};

#define PIL_RX_SIZE 256u
static volatile uint8_t pil_rx_buf[PIL_RX_SIZE];
static volatile uint32_t pil_rx_head, pil_rx_tail;

void pil_rx_push(uint8_t b)
{
    uint32_t next = (pil_rx_head + 1u) % PIL_RX_SIZE;
    if (next != pil_rx_tail) { /* full: the byte is lost and the frame check fails */
        pil_rx_buf[pil_rx_head] = b;
        pil_rx_head = next;
    }
}

int pil_rx(void)
{
    int b;
    if (pil_rx_tail == pil_rx_head) {
        return -1;
    }
    b = pil_rx_buf[pil_rx_tail];
    pil_rx_tail = (pil_rx_tail + 1u) % PIL_RX_SIZE;
    return b;
}

void pil_rx_wait(void)
{
    __asm volatile("cpsid i" ::: "memory");
    if (pil_rx_tail == pil_rx_head) {
        __asm volatile("wfi" ::: "memory"); /* a pending interrupt wakes it even with PRIMASK set */
    }
    __asm volatile("cpsie i" ::: "memory");
}

uint32_t pil_systick(void)
{
    return PIL_SYST_CVR;
}

static uint32_t pil_semihost(uint32_t op, uint32_t arg)
{
    register uint32_t r0 __asm("r0") = op;
    register uint32_t r1 __asm("r1") = arg;
    __asm volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void pil_exit(int code)
{
    /* SYS_EXIT with ADP_Stopped_ApplicationExit (0x20026) exits 0; ADP_Stopped_RunTimeErrorUnknown (0x20023)
     * exits 1: the code itself is only passed through SYS_EXIT_EXTENDED, so report it first */
    if (code != 0) {
        static char msg[] = "pil: exit code 0\n";
        msg[15] = (char)('0' + (code % 10));
        pil_puts(msg);
    }
    (void)pil_semihost(0x18u, code == 0 ? 0x20026u : 0x20023u);
    for (;;) {
    }
}

void pil_puts(const char *s)
{
    (void)pil_semihost(0x04u, (uint32_t)(uintptr_t)s);
}

void pil_board_systick_init(void);
void pil_board_systick_init(void)
{
    PIL_SYST_RVR = 0x00FFFFFFu;
    PIL_SYST_CVR = 0u;
    PIL_SYST_CSR = 5u; /* enabled, processor clock, no interrupt */
}
