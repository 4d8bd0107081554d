; UART0's receive and transmit interrupts, in assembly: avr-gcc's versions save
; r0, r1 and RAMPZ and take ~60 cycles a byte each way; these save only what they
; use (~36). At 1 Mbaud a byte is 160 cycles, and every byte of every frame goes
; through one of them. The rings and their 8-bit indices are firmware/src/uart.c's.

#include <avr/io.h>

        .section .text.vehil_uart_isr, "ax", @progbits

; A received byte into the RX ring; a full ring or a byte the hardware lost
; (DOR0) counts an overrun (saturating at 0xFFFF).
        .global USART0_RX_vect
USART0_RX_vect:
        push    r24
        in      r24, _SFR_IO_ADDR(SREG)
        push    r24
        push    r25
        push    r30
        push    r31
        lds     r25, _SFR_MEM_ADDR(UCSR0A)
        lds     r24, _SFR_MEM_ADDR(UDR0)
        lds     r30, uart_rx_head
        ldi     r31, 0
        subi    r30, lo8(-(uart_rx_buf))
        sbci    r31, hi8(-(uart_rx_buf))
        st      Z, r24                  ; the slot at head is always free
        lds     r30, uart_rx_head
        inc     r30
        lds     r24, uart_rx_tail
        cp      r30, r24
        breq    1f                      ; full: the byte is dropped
        sts     uart_rx_head, r30
        sbrs    r25, DOR0
        rjmp    2f
1:      lds     r24, uart_rx_lost
        lds     r25, uart_rx_lost + 1
        adiw    r24, 1
        breq    2f                      ; already 0xFFFF
        sts     uart_rx_lost + 1, r25
        sts     uart_rx_lost, r24
2:      pop     r31
        pop     r30
        pop     r25
        pop     r24
        out     _SFR_IO_ADDR(SREG), r24
        pop     r24
        reti

; The next released byte from the TX ring; with none left, the interrupt turns
; itself off until uart_tx_close() releases more.
        .global USART0_UDRE_vect
USART0_UDRE_vect:
        push    r24
        in      r24, _SFR_IO_ADDR(SREG)
        push    r24
        push    r30
        push    r31
        lds     r30, uart_tx_tail
        lds     r24, uart_tx_head
        cp      r30, r24
        breq    1f
        mov     r24, r30
        inc     r24
        sts     uart_tx_tail, r24
        ldi     r31, 0
        subi    r30, lo8(-(uart_tx_buf))
        sbci    r31, hi8(-(uart_tx_buf))
        ld      r24, Z
        sts     _SFR_MEM_ADDR(UDR0), r24
2:      pop     r31
        pop     r30
        pop     r24
        out     _SFR_IO_ADDR(SREG), r24
        pop     r24
        reti
1:      lds     r24, _SFR_MEM_ADDR(UCSR0B)
        andi    r24, ~(1 << UDRIE0)
        sts     _SFR_MEM_ADDR(UCSR0B), r24
        rjmp    2b
