/* Timer1 at clk/1 with a software overflow count: a 32-bit cycle counter. */
#ifndef VEHIL_CYCLES_H
#define VEHIL_CYCLES_H

#include <avr/io.h>
#include <stdint.h>

void cycles_init(void);

/* Timer1 overflows since cycles_init() (its interrupt, cycles.c): the count's high half. */
extern volatile uint16_t cycles_overflows;

/* Inline, and in assembly: a call with its 32-bit return costs more than the read,
 * and in C the two halves went through memory; every frame the core handles reads it.
 * Interrupts are off between the reads; an overflow pending but not yet serviced
 * belongs to a low count just after it (bit 15 clear). TCNT1's low byte is read
 * first, which latches its high byte. */
static inline uint32_t cycles_now(void)
{
    uint32_t t;
    __asm__ __volatile__("in __tmp_reg__, __SREG__\n\t"
                         "cli\n\t"
                         "lds %A0, %[tcnt]\n\t"
                         "lds %B0, %[tcnt] + 1\n\t"
                         "lds %C0, %[ovf]\n\t"
                         "lds %D0, %[ovf] + 1\n\t"
                         "sbis %[tifr], %[tov]\n\t"
                         "rjmp 1f\n\t"
                         "sbrc %B0, 7\n\t"
                         "rjmp 1f\n\t"
                         "subi %C0, 0xFF\n\t" /* + 1 */
                         "sbci %D0, 0xFF\n\t"
                         "1: out __SREG__, __tmp_reg__"
                         : "=&d"(t)
                         : [tcnt] "n"(_SFR_MEM_ADDR(TCNT1)), [ovf] "i"(&cycles_overflows), [tifr] "I"(_SFR_IO_ADDR(TIFR1)),
                           [tov] "I"(TOV1)
                         : "memory");
    return t;
}

#endif
