/* pil_nrf51.c -- micro:bit (nRF51, Cortex-M0): UART0 at 0x40002000, receive interrupt IRQ 2. */
#include "pil_board.h"

#define UART_REG(off) (*(volatile uint32_t *)(0x40002000u + (off)))
#define STARTRX UART_REG(0x000u)
#define STARTTX UART_REG(0x008u)
#define RXDRDY UART_REG(0x108u)
#define TXDRDY UART_REG(0x11Cu)
#define INTENSET UART_REG(0x304u)
#define ENABLE UART_REG(0x500u)
#define RXD UART_REG(0x518u)
#define TXD UART_REG(0x51Cu)

void pil_board_systick_init(void);
void pil_uart_irq(void);

void pil_board_init(void)
{
    ENABLE = 4u;
    INTENSET = 1u << 2; /* RXDRDY */
    STARTRX = 1u;
    STARTTX = 1u;
    PIL_NVIC_ISER = 1u << PIL_UART_IRQ;
    pil_board_systick_init();
}

void pil_uart_irq(void)
{
    while (RXDRDY) {
        RXDRDY = 0u;
        pil_rx_push((uint8_t)RXD); /* reading RXD raises RXDRDY again while bytes remain */
    }
}

void pil_tx(const uint8_t *data, uint32_t n)
{
    uint32_t i;
    for (i = 0; i < n; ++i) {
        TXDRDY = 0u;
        TXD = data[i];
        while (!TXDRDY) {
        }
    }
}
