; UART0's receive and transmit interrupts, in assembly: avr-gcc's versions save
; r0, r1 and RAMPZ and take ~60 cycles a byte each way; these touch no flag on their
; common path (CPSE compares and ST/LD with post-increment step an index without
; one), so they need not save SREG: 44 and 39 cycles, response, call and return
; included. At 1 Mbaud a byte is 160 cycles, and every byte of every frame goes
; through one of them. Each reads or writes UDR0 first, so a byte waits the least
; for it when the two interrupts meet.
; The rings and their 8-bit indices are firmware/src/uart.c's; each ring is on a
; 256-byte boundary, so a slot's address is the ring's high byte and the index
; (stepping Z past slot 255 carries into r31 and leaves r30 at 0: the index wraps).

#include <avr/io.h>

#include "uart.h"

        .section .text.vehil_uart_isr, "ax", @progbits

; A received byte into the RX ring; a full ring or a byte the hardware lost
; (DOR0, read before UDR0) counts an overrun (saturating at 0xFFFF).
        .global USART0_RX_vect
USART0_RX_vect:
        push    r24
        push    r30
        push    r31
        lds     r31, _SFR_MEM_ADDR(UCSR0A)
        lds     r24, _SFR_MEM_ADDR(UDR0)
        sbrc    r31, DOR0
        rjmp    lost
take:   lds     r30, uart_rx_head
        ldi     r31, hi8(uart_rx_buf)
        st      Z+, r24                 ; the slot at head is always free
        lds     r24, uart_rx_tail
        cpse    r30, r24
        sts     uart_rx_head, r30       ; not full: the byte is in
        cpse    r30, r24
        rjmp    rx_out
        rcall   count                   ; full: the byte is dropped
rx_out: pop     r31
        pop     r30
        pop     r24
        reti
lost:   rcall   count                   ; the hardware lost the byte before this one
        rjmp    take

; One more byte lost; keeps SREG and r24, uses r30 and r31.
count:  push    r24
        in      r24, _SFR_IO_ADDR(SREG)
        lds     r30, uart_rx_lost
        lds     r31, uart_rx_lost + 1
        adiw    r30, 1
        breq    1f                      ; already 0xFFFF
        sts     uart_rx_lost + 1, r31
        sts     uart_rx_lost, r30
1:      out     _SFR_IO_ADDR(SREG), r24
        pop     r24
        ret

; The next released byte from the TX ring. The interrupt is on only while the ring
; holds released bytes (uart_tx_close() turns it on with at least one): it sends one,
; and turns itself off when that was the last.
        .global USART0_UDRE_vect
USART0_UDRE_vect:
        push    r24
        push    r30
        push    r31
        lds     r30, uart_tx_tail
        ldi     r31, hi8(uart_tx_buf)
        ld      r24, Z+
        sts     _SFR_MEM_ADDR(UDR0), r24
        sts     uart_tx_tail, r30
        lds     r24, uart_tx_head
        cpse    r30, r24
        rjmp    tx_out
        ldi     r24, UART_UCSR0B_ON     ; sent them all: UDRIE0 off
        sts     _SFR_MEM_ADDR(UCSR0B), r24
tx_out: pop     r31
        pop     r30
        pop     r24
        reti
