/* UART_POLL, for the assembly that runs with interrupts off (uart_isr.S, frame_avr.S):
 * one look at UART0 that does what its two interrupts would, in ~8 cycles when there is
 * nothing to do, ~20 a byte moved (the interrupts take 49 and 41). At 2 Mbaud a byte is
 * 80 cycles each way, and an interrupt per byte both ways left the core nothing else.
 *
 * A received byte goes into the RX ring (a full ring, or DOR0 set, counts an overrun as
 * the RX interrupt does); with UDRE0 set, the next released byte of the TX ring goes into
 * UDR0 (the last one turns the UDRE interrupt off). T is a scratch register; Z and SREG
 * are clobbered. */
#ifndef VEHIL_UART_POLL_H
#define VEHIL_UART_POLL_H

#include <avr/io.h>

.macro UART_POLL t
        lds     \t, _SFR_MEM_ADDR(UCSR0A)
        sbrs    \t, RXC0
        rjmp    .Ltx\@
        sbrc    \t, DOR0
        rcall   uart_count_lost         ; the byte before this one was lost
        lds     \t, _SFR_MEM_ADDR(UDR0)
        lds     r30, uart_rx_head
        ldi     r31, hi8(uart_rx_buf)   ; on a 256-byte boundary (uart.c)
        st      Z, \t                   ; the slot at head is always free
        inc     r30
        lds     \t, uart_rx_tail
        cpse    r30, \t
        rjmp    .Lkeep\@
        rcall   uart_count_lost         ; full: the byte is dropped
        rjmp    .Lrxed\@
.Lkeep\@:
        sts     uart_rx_head, r30
.Lrxed\@:
        lds     \t, _SFR_MEM_ADDR(UCSR0A)
.Ltx\@:
        sbrs    \t, UDRE0
        rjmp    .Ldone\@
        lds     r30, uart_tx_tail
        lds     r31, uart_tx_head
        cp      r30, r31
        breq    .Ldone\@                ; nothing released
        ldi     r31, hi8(uart_tx_buf)
        ld      \t, Z
        sts     _SFR_MEM_ADDR(UDR0), \t
        inc     r30
        sts     uart_tx_tail, r30
        lds     r31, uart_tx_head
        cpse    r30, r31
        rjmp    .Ldone\@
        rcall   uart_tx_quiet           ; the last one
.Ldone\@:
.endm

#endif
