#include "cycles.h"

#include <avr/interrupt.h>
#include <avr/io.h>

volatile uint16_t cycles_overflows; /* also counted by uart_rx_wait, interrupts off */

ISR(TIMER1_OVF_vect) { cycles_overflows++; }

void cycles_init(void)
{
    TCCR1A = 0;
    TCNT1 = 0;
    TIFR1 = _BV(TOV1);
    TIMSK1 = _BV(TOIE1);
    TCCR1B = _BV(CS10); /* normal mode, no prescaler */
}

uint32_t cycles_now(void)
{
    uint8_t sreg = SREG;
    cli();
    uint16_t low = TCNT1;
    /* An overflow not yet counted (its interrupt pending while interrupts are off) is
     * counted here, and the count read again after it. */
    if (TIFR1 & _BV(TOV1)) {
        TIFR1 = _BV(TOV1); /* writing 1 clears it */
        cycles_overflows++;
        low = TCNT1;
    }
    uint16_t high = cycles_overflows;
    SREG = sreg;
    return ((uint32_t)high << 16) | low;
}
