/* pil_board.h -- the board interface of the processor-in-the-loop firmware: UART, cycle counter, exit.
 * One implementation per board: pil_mps2.c (mps2-an386, Cortex-M4, CMSDK UART0) and pil_nrf51.c (micro:bit,
 * nRF51 Cortex-M0, UART0). Received bytes are queued by the UART receive interrupt; the main loop sleeps on
 * WFI while the queue is empty. */
#ifndef PIL_BOARD_H
#define PIL_BOARD_H

#include <stdint.h>

void pil_board_init(void);                   /* UART on with its receive interrupt, SysTick free-running */
int pil_rx(void);                            /* next received byte, or -1 when none is queued */
void pil_rx_wait(void);                      /* sleep (WFI) until a byte is queued */
void pil_tx(const uint8_t *data, uint32_t n); /* send bytes (blocking) */
void pil_rx_push(uint8_t b);                 /* called by the receive interrupt of the board */
uint32_t pil_systick(void);                  /* SysTick current value (counts down, 24 bits) */
void pil_exit(int code);                     /* semihosting SYS_EXIT */
void pil_puts(const char *s);                /* semihosting SYS_WRITE0 */

#define PIL_SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define PIL_SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define PIL_SYST_CVR (*(volatile uint32_t *)0xE000E018u)
#define PIL_NVIC_ISER (*(volatile uint32_t *)0xE000E100u)

#endif /* PIL_BOARD_H */
