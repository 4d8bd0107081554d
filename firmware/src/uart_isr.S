; UART0's receive and transmit interrupts, in assembly (uart_serve.inc: the work they
; share with the frame loops' service points, uart.h). avr-gcc's interrupts save r0, r1 and RAMPZ and take ~60 cycles a byte
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
#include "uart_serve.inc"

        .section .text.vehil_uart_isr, "ax", @progbits

        .global USART0_RX_vect
USART0_RX_vect:
        push    r24
        push    r30
        push    r31
        lds     r31, _SFR_MEM_ADDR(UCSR0A)
        lds     r24, _SFR_MEM_ADDR(UDR0)
        RX_TAKE r24, rx_out, rcall
rx_out: pop     r31
        pop     r30
        pop     r24
        reti

; One more byte lost; keeps SREG and r24, uses r30 and r31.
        .global uart_rx_count
uart_rx_count:
        push    r24
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
