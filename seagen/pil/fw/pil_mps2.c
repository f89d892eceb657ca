/* pil_mps2.c -- mps2-an386 (Cortex-M4): CMSDK APB UART0 at 0x40004000, receive interrupt IRQ 0. */
#include "pil_board.h"

#define UART_DATA (*(volatile uint32_t *)0x40004000u)
#define UART_STATE (*(volatile uint32_t *)0x40004004u)
#define UART_CTRL (*(volatile uint32_t *)0x40004008u)
#define UART_INT (*(volatile uint32_t *)0x4000400Cu)
#define UART_BAUDDIV (*(volatile uint32_t *)0x40004010u)
#define STATE_TXFULL 1u
#define STATE_RXFULL 2u

void pil_board_systick_init(void);
void pil_uart_irq(void);

void pil_board_init(void)
{
    UART_BAUDDIV = 16u;
    UART_CTRL = 1u | 2u | 8u; /* TX, RX, RX interrupt */
    PIL_NVIC_ISER = 1u << PIL_UART_IRQ;
    pil_board_systick_init();
}

void pil_uart_irq(void)
{
    UART_INT = 2u;
    while (UART_STATE & STATE_RXFULL) {
        pil_rx_push((uint8_t)UART_DATA);
        UART_INT = 2u;
    }
}

void pil_tx(const uint8_t *data, uint32_t n)
{
    uint32_t i;
    for (i = 0; i < n; ++i) {
        while (UART_STATE & STATE_TXFULL) {
        }
        UART_DATA = data[i];
    }
}
