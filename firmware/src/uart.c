#include "uart.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/wdt.h>
#include <util/atomic.h>

/* Shared with the interrupts in uart_isr.S and frame_avr.S, which address a slot by
 * its index alone: each ring is on a 256-byte boundary. The offline images' linker
 * script puts them first in RAM (host/vehil/build/ldscript.py), where that costs no
 * padding; another script pads to the boundary. */
#define RING __attribute__((section(".data.rings"), aligned(256)))
volatile uint8_t uart_rx_buf[UART_RX_SIZE] RING;
volatile uint8_t uart_rx_head; /* written by the RX interrupt */
volatile uint8_t uart_rx_tail;
volatile uint16_t uart_rx_lost;
volatile uint8_t uart_tx_buf[UART_TX_SIZE] RING;
volatile uint8_t uart_tx_head; /* released bytes end here */
volatile uint8_t uart_tx_tail; /* advanced by the UDRE interrupt or a service point */

/* A service point tests UCSR0A & UCSR0B: each status bit where its interrupt's enable is. */
typedef char uart_enables_match[(RXC0 == RXCIE0 && UDRE0 == UDRIE0) ? 1 : -1];
uint8_t uart_frame_polled;
uint8_t uart_tx_write; /* the next byte appended goes here */
uint8_t uart_tx_held;  /* the placeholder */
static uint32_t current_baud;

int32_t uart_ubrr(uint32_t baud)
{
    if (baud == 0) {
        return -1;
    }
    int32_t ubrr = (int32_t)((F_CPU + 4UL * baud) / (8UL * baud)) - 1; /* rounded */
    return (ubrr < 0 || ubrr > 4095) ? -1 : ubrr;
}

void uart_init(uint32_t baud)
{
    UCSR0B = 0;
    /* U2X0 before UBRR0: the chip does not care, but simavr fixes the bit time when
     * UBRR0 is written, from U2X0 as it is then (the other order ran at half the baud). */
    UCSR0A = _BV(U2X0);
    UBRR0 = (uint16_t)uart_ubrr(baud);
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00); /* 8N1 */
    UCSR0B = UART_UCSR0B_ON;
    current_baud = baud;
    uart_frame_polled = 10u * (F_CPU / baud) < UART_RX_ISR_CYCLES + UART_TX_ISR_CYCLES;
}

/* The board's idle loop. QEMU runs it ~30x slower, and so answers ~30x later,
 * when it straddles a 256-byte flash page (a translation block ends at the
 * boundary); aligning the function keeps the loop on one page. */
__attribute__((noinline, aligned(256))) const uint8_t *uart_rx_wait(uint8_t *n)
{
    uint8_t tail = uart_rx_tail;
    uint8_t head;
    do {
        wdt_reset(); /* on every call: a board kept busy by a full ring never idles here */
        head = uart_rx_head;
    } while (head == tail);
    /* Up to the head, or to the ring's end: the part after the wrap comes next call. */
    *n = head > tail ? (uint8_t)(head - tail) : (uint8_t)(UART_RX_SIZE - tail);
    return (const uint8_t *)&uart_rx_buf[tail];
}

void uart_rx_release(uint8_t n) { uart_rx_tail = (uint8_t)(uart_rx_tail + n); }

void uart_tx_open(void)
{
    uart_tx_held = uart_tx_write;
    uart_tx_put(0);
}

void uart_tx_close(uint8_t code)
{
    uart_tx_buf[uart_tx_held] = code;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        uart_tx_head = uart_tx_write;
        UCSR0A |= _BV(TXC0); /* writing 1 clears it: it now means "these bytes are out" */
        UCSR0B |= _BV(UDRIE0);
    }
}

void uart_flush(void)
{
    while (uart_tx_tail != uart_tx_head) {
    }
    /* Then the shift register. Bounded: QEMU sends at once and may never set TXC. */
    uint32_t spins = F_CPU / current_baud * 4u;
    while (!(UCSR0A & _BV(TXC0)) && spins-- > 0u) {
    }
}

uint32_t uart_baud(void) { return current_baud; }
