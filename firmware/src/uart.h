/* UART0 with RX and TX rings of 256 bytes: 8-bit indices, which the core reads and
 * writes in one instruction and which wrap by themselves.
 *
 * Interrupts move the bytes between UDR0 and the rings, a byte at a time, but where
 * they would cost more than a byte's time, a byte each way (UART_RX_ISR_CYCLES +
 * UART_TX_ISR_CYCLES, 83, against 80 cycles at 2 Mbaud): there the frame path's loops
 * (frame_avr.S), through which every byte of a request and of its reply goes, run
 * with interrupts off and do that work at their service points (uart_serve.inc:
 * UART_POLL, SERVE_STUB), for a fraction of an interrupt's cycles: for the call, the
 * rings' indices and the interrupt enables are in registers (POLLED_BEGIN), so a
 * service point's test is the interrupts' own condition read from a register, and the
 * enables are written back at the end (POLLED_END) with I set back as it was: a byte
 * is taken or sent by exactly one of them. The service points are ~35-72 cycles apart
 * (every second byte in the request's and the PONG's loops), within the byte time
 * (80 cycles at 2 Mbaud) UDR0 holds a byte for and the three byte times the receiver
 * holds bytes for; between the loops, and below 2 Mbaud, the interrupts
 * serve, so the idle wait, a step and every other handler run as before. (Polling at
 * 1 Mbaud was measured only on simavr's own UART timing, where it cost ~8 %: that UDR0
 * is not double-buffered, so a service point's latency added to every byte's time.) */
#ifndef VEHIL_UART_H
#define VEHIL_UART_H

/* UCSR0B while the UART runs: receiver, transmitter and the receive interrupt on; the
 * UDRE interrupt comes on with each released reply (uart_isr.S writes this to end it). */
#define UART_UCSR0B_ON (_BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0))

#ifndef __ASSEMBLER__
#include <stdint.h>

#define UART_DEFAULT_BAUD 1000000UL
#define UART_RX_SIZE 256u /* holds a window of frames while a step runs */
#define UART_TX_SIZE 256u

void uart_init(uint32_t baud);
/* Waits for received bytes, keeping the watchdog fed meanwhile; returns where they
 * lie in the RX ring and how many follow there without a wrap. */
const uint8_t *uart_rx_wait(uint8_t *n);
/* Gives the ring back the first n of them. */
void uart_rx_release(uint8_t n);
/* The TX ring's side of port.h: append, hold back from a placeholder, release. */
void uart_tx_open(void);
void uart_tx_close(uint8_t code);

/* Each interrupt's cycles per byte, call and return included (uart_isr.S; vehil
 * profile --functions counts them). */
#define UART_RX_ISR_CYCLES 44u
#define UART_TX_ISR_CYCLES 39u
extern volatile uint8_t uart_rx_head;
extern volatile uint8_t uart_tx_buf[UART_TX_SIZE];
extern volatile uint8_t uart_tx_tail;
extern uint8_t uart_tx_write;
extern uint8_t uart_tx_held; /* the placeholder's slot (frame_tx_avr.S moves it too) */

/* 1 where the frame path's loops serve the UART (see above), set by uart_init(). */
extern uint8_t uart_frame_polled;

/* The TX ring (uart.c; the UDRE interrupt or a service point advances the tail). Appending
 * is inline: every byte of every reply goes through it. */
static inline void uart_tx_put(uint8_t byte)
{
    uint8_t w = uart_tx_write;
    while ((uint8_t)(w + 1u) == uart_tx_tail) {
        /* full: the UDRE interrupt drains what was released */
    }
    uart_tx_buf[w] = byte;
    uart_tx_write = (uint8_t)(w + 1u);
}
/* Waits until the last released byte has been shifted out. */
void uart_flush(void);
uint32_t uart_baud(void);
/* UBRR for baud with U2X, or -1 if out of range. */
int32_t uart_ubrr(uint32_t baud);
/* Received bytes dropped for a full ring or lost by the receiver (uart_isr.S counts them,
 * saturating); port_inline.h reads it. */
extern volatile uint16_t uart_rx_lost;

#endif /* __ASSEMBLER__ */

#endif
