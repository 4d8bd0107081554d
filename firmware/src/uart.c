#include "uart.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/wdt.h>
#include <util/atomic.h>

static volatile uint8_t rx_buf[UART_RX_SIZE];
static volatile uint8_t rx_head; /* written by the RX interrupt */
static volatile uint8_t rx_tail;
static volatile uint16_t rx_overruns;

static volatile uint8_t tx_buf[UART_TX_SIZE];
static volatile uint8_t tx_head; /* released bytes end here */
static volatile uint8_t tx_tail; /* advanced by the UDRE interrupt */
static uint8_t tx_write;         /* the next byte appended goes here */
static uint8_t tx_held;          /* the placeholder */

static uint32_t current_baud;

ISR(USART0_RX_vect)
{
    uint8_t lost = UCSR0A & _BV(DOR0); /* the hardware dropped a byte before this one */
    uint8_t byte = UDR0;
    uint8_t head = rx_head;
    uint8_t next = (uint8_t)(head + 1u);
    if (next != rx_tail) {
        rx_buf[head] = byte;
        rx_head = next;
    } else {
        lost = 1;
    }
    if (lost && rx_overruns != UINT16_MAX) {
        rx_overruns++;
    }
}

ISR(USART0_UDRE_vect)
{
    uint8_t tail = tx_tail;
    if (tail == tx_head) {
        UCSR0B &= (uint8_t)~_BV(UDRIE0);
        return;
    }
    UDR0 = tx_buf[tail];
    tx_tail = (uint8_t)(tail + 1u);
}

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
    UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
    current_baud = baud;
}

/* The board's idle loop. QEMU runs it ~30x slower, and so answers ~30x later,
 * when it straddles a 256-byte flash page (a translation block ends at the
 * boundary); aligning the function keeps the loop on one page. */
__attribute__((noinline, aligned(256))) uint8_t uart_wait_byte(void)
{
    uint8_t tail = rx_tail;
    while (rx_head == tail) {
        wdt_reset();
    }
    uint8_t byte = rx_buf[tail];
    rx_tail = (uint8_t)(tail + 1u);
    return byte;
}

void uart_tx_put(uint8_t byte)
{
    uint8_t w = tx_write;
    while ((uint8_t)(w + 1u) == tx_tail) {
        /* full: the UDRE interrupt drains what was released */
    }
    tx_buf[w] = byte;
    tx_write = (uint8_t)(w + 1u);
}

void uart_tx_open(void)
{
    tx_held = tx_write;
    uart_tx_put(0);
}

void uart_tx_close(uint8_t code)
{
    tx_buf[tx_held] = code;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        tx_head = tx_write;
        UCSR0A |= _BV(TXC0); /* writing 1 clears it: it now means "these bytes are out" */
        UCSR0B |= _BV(UDRIE0);
    }
}

void uart_flush(void)
{
    while (tx_tail != tx_head) {
    }
    /* Then the shift register. Bounded: QEMU sends at once and may never set TXC. */
    uint32_t spins = F_CPU / current_baud * 4u;
    while (!(UCSR0A & _BV(TXC0)) && spins-- > 0u) {
    }
}

uint32_t uart_baud(void) { return current_baud; }

uint16_t uart_rx_overruns(void)
{
    uint16_t n;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { n = rx_overruns; }
    return n;
}
