; UART0's receive and transmit work, in assembly, done by its interrupts or, where
; they would cost more than a byte's time, by uart_serve in the frame loops with
; interrupts off (uart.h). avr-gcc's interrupts save r0, r1 and RAMPZ and take ~60 cycles a byte
; each way; these touch no flag on their common path (CPSE compares and ST/LD with
; post-increment step an index without one), so they need not save SREG: 44 and 39
; cycles, response, call and return included. At 1 Mbaud a byte is 160 cycles, and
; every byte the board takes or sends while it idles or runs a step goes through one
; of them. Each reads or writes UDR0 first, so a byte waits the least for it when the
; two interrupts meet.
; The rings and their 8-bit indices are firmware/src/uart.c's; each ring is on a
; 256-byte boundary, so a slot's address is the ring's high byte and the index
; (stepping Z past slot 255 carries into r31 and leaves r30 at 0: the index wraps).

#include <avr/io.h>

#include "uart.h"

        .section .text.vehil_uart_isr, "ax", @progbits

; A received byte (\byte, UCSR0A read before it in r31) into the RX ring; a full ring
; or a byte the hardware lost (DOR0) counts an overrun (saturating at 0xFFFF). Jumps
; to \again when it is in or dropped. Uses r30, r31.
.macro RX_TAKE byte, again
        sbrc    r31, DOR0
        rcall   count                   ; the hardware lost the byte before this one
        lds     r30, uart_rx_head
        ldi     r31, hi8(uart_rx_buf)
        st      Z+, \byte               ; the slot at head is always free
        lds     r31, uart_rx_tail
        cpse    r30, r31
        sts     uart_rx_head, r30       ; not full: the byte is in
        cpse    r30, r31
        rjmp    \again
        rcall   count                   ; full: the byte is dropped
        rjmp    \again
.endm

; The next released byte from the TX ring into UDR0 (its slot read into \byte); when it
; was the last, UDRIE0 goes off: the interrupt is on exactly while the ring holds
; released bytes (uart_tx_close() and frame_tx_run turn it on with at least one), and
; the polled path reads that bit the same way. Uses r30, r31; \done when it is sent.
.macro TX_GIVE byte, done
        lds     r30, uart_tx_tail
        ldi     r31, hi8(uart_tx_buf)
        ld      \byte, Z+
        sts     _SFR_MEM_ADDR(UDR0), \byte
        sts     uart_tx_tail, r30
        lds     r31, uart_tx_head
        cpse    r30, r31
        rjmp    \done
        ldi     r31, UART_UCSR0B_ON     ; sent them all: UDRIE0 off
        sts     _SFR_MEM_ADDR(UCSR0B), r31
.endm

        .global USART0_RX_vect
USART0_RX_vect:
        push    r24
        push    r30
        push    r31
        lds     r31, _SFR_MEM_ADDR(UCSR0A)
        lds     r24, _SFR_MEM_ADDR(UDR0)
        RX_TAKE r24, rx_out
rx_out: pop     r31
        pop     r30
        pop     r24
        reti

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

        .global USART0_UDRE_vect
USART0_UDRE_vect:
        push    r24
        push    r30
        push    r31
        TX_GIVE r24, tx_out
tx_out: pop     r31
        pop     r30
        pop     r24
        reti

; The frame loops' service point (uart.h), with interrupts off: what the two
; interrupts would do now. Every byte the receiver holds (it holds two
; and a third shifting in) into the RX ring, then one released byte out if UDR0 is
; free. Keeps SREG and every register but r0, r30 and r31, so frame_avr.S's loops
; call it between bytes (their UART_POLL macro).
        .global uart_serve
uart_serve:
        lds     r31, _SFR_MEM_ADDR(UCSR0A)
        sbrs    r31, RXC0
        rjmp    serve_tx
        lds     r0, _SFR_MEM_ADDR(UDR0)
        RX_TAKE r0, uart_serve
serve_tx:                               ; (no skip over RET: QEMU 7.2 loops on one)
        sbrs    r31, UDRE0
        rjmp    serve_out
        lds     r30, _SFR_MEM_ADDR(UCSR0B)
        sbrs    r30, UDRIE0
        rjmp    serve_out               ; nothing released
        TX_GIVE r0, serve_out
serve_out:
        ret
