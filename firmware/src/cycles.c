#include "cycles.h"

#include <avr/interrupt.h>
#include <avr/io.h>

volatile uint16_t cycles_overflows;

ISR(TIMER1_OVF_vect) { cycles_overflows++; }

void cycles_init(void)
{
    TCCR1A = 0;
    TCNT1 = 0;
    TIFR1 = _BV(TOV1);
    TIMSK1 = _BV(TOIE1);
    TCCR1B = _BV(CS10); /* normal mode, no prescaler */
}
