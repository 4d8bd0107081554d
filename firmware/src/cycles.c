#include "cycles.h"

#include <avr/interrupt.h>
#include <avr/io.h>

static volatile uint16_t overflows;

ISR(TIMER1_OVF_vect) { overflows++; }

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
    uint16_t high = overflows;
    /* An overflow pending but not yet serviced belongs to a low count just after it. */
    if ((TIFR1 & _BV(TOV1)) && low < 0x8000u) {
        high++;
    }
    SREG = sreg;
    /* The halves placed by a union: avr-gcc builds the shift-and-or in ~17 more cycles. */
    union {
        uint32_t count;
        uint16_t half[2]; /* little-endian */
    } t = {.half = {low, high}};
    return t.count;
}
