/* UART0 with interrupt-driven RX and TX ring buffers, U2X on. */
#ifndef VEHIL_UART_H
#define VEHIL_UART_H

#include <stdint.h>

#define UART_DEFAULT_BAUD 1000000UL
#define UART_RX_SIZE 512u /* holds a window of frames while a step runs */
#define UART_TX_SIZE 256u /* power of two: 8-bit indices wrap by themselves */

void uart_init(uint32_t baud);
/* Waits for the next received byte, keeping the watchdog fed meanwhile. */
uint8_t uart_wait_byte(void);
/* Queues bytes; waits while the TX ring is full. */
void uart_write(const uint8_t *data, uint16_t len);
/* Waits until the last queued byte has been shifted out. */
void uart_flush(void);
uint32_t uart_baud(void);
/* UBRR for baud with U2X, or -1 if out of range. */
int32_t uart_ubrr(uint32_t baud);
uint16_t uart_rx_overruns(void);

#endif
