#include "uart.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/wdt.h>
#include <util/atomic.h>

static volatile uint8_t rx_buf[UART_RX_SIZE];
static volatile uint16_t rx_head; /* written by the ISR */
static uint16_t rx_tail;
static volatile uint16_t rx_overruns;

static volatile uint8_t tx_buf[UART_TX_SIZE];
static uint8_t tx_head;
static volatile uint8_t tx_tail; /* advanced by the ISR */

static uint32_t current_baud;

ISR(USART0_RX_vect)
{
    uint8_t hw_overrun = UCSR0A & _BV(DOR0);
    uint8_t byte = UDR0;
    uint16_t next = (uint16_t)((rx_head + 1u) % UART_RX_SIZE);
    if (next == rx_tail || hw_overrun) {
        if (rx_overruns != UINT16_MAX) {
            rx_overruns++;
        }
    }
    if (next != rx_tail) {
        rx_buf[rx_head] = byte;
        rx_head = next;
    }
}

ISR(USART0_UDRE_vect)
{
    if (tx_tail == tx_head) {
        UCSR0B &= (uint8_t)~_BV(UDRIE0);
        return;
    }
    UDR0 = tx_buf[tx_tail];
    tx_tail = (uint8_t)(tx_tail + 1u);
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
    uint16_t head;
    do {
        wdt_reset();
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { head = rx_head; }
    } while (head == rx_tail);
    uint8_t byte = rx_buf[rx_tail];
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { rx_tail = (uint16_t)((rx_tail + 1u) % UART_RX_SIZE); }
    return byte;
}

void uart_write(const uint8_t *data, uint16_t len)
{
    /* Copy as much as fits, then publish it with one atomic update: a reply costs
     * one interrupt-masked section, not one per byte. */
    while (len > 0u) {
        uint8_t head = tx_head;
        while ((uint8_t)(head + 1u) == tx_tail) {
            /* full: the UDRE interrupt drains it */
        }
        while (len > 0u && (uint8_t)(head + 1u) != tx_tail) {
            tx_buf[head] = *data++;
            head = (uint8_t)(head + 1u);
            len--;
        }
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
        {
            tx_head = head;
            UCSR0A |= _BV(TXC0); /* writing 1 clears it: it now means "these bytes are out" */
            UCSR0B |= _BV(UDRIE0);
        }
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
