#include "cycles.h"

#include <avr/interrupt.h>
#include <avr/io.h>

volatile uint16_t cycles_overflows;

/* In assembly: avr-gcc's saves r0, r1, r24 and r25 for the 16-bit increment; this one
 * needs r24 alone, and reaches the high byte once in 256 overflows. */
ISR(TIMER1_OVF_vect, ISR_NAKED)
{
    __asm__ __volatile__("push r24\n\t"
                         "in r24, __SREG__\n\t"
                         "push r24\n\t"
                         "lds r24, %[ovf]\n\t"
                         "subi r24, 0xFF\n\t" /* + 1 */
                         "sts %[ovf], r24\n\t"
                         "brne 1f\n\t"
                         "lds r24, %[ovf] + 1\n\t"
                         "subi r24, 0xFF\n\t"
                         "sts %[ovf] + 1, r24\n\t"
                         "1: pop r24\n\t"
                         "out __SREG__, r24\n\t"
                         "pop r24\n\t"
                         "reti" ::[ovf] "i"(&cycles_overflows));
}

void cycles_init(void)
{
    TCCR1A = 0;
    TCNT1 = 0;
    TIFR1 = _BV(TOV1);
    TIMSK1 = _BV(TOIE1);
    TCCR1B = _BV(CS10); /* normal mode, no prescaler */
}
