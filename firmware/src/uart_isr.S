; UART0's receive and transmit interrupts, in assembly: avr-gcc's versions save
; r0, r1 and RAMPZ and take ~60 cycles a byte each way; these save only what they
; use (49 and 41 cycles, call and return included). At 1 Mbaud a byte is 160 cycles,
; and every byte of every frame goes through one of them. The rings and their 8-bit
; indices are firmware/src/uart.c's; each ring is on a 256-byte boundary, so a slot's
; address is the ring's high byte and the index.

#include <avr/io.h>

        .section .text.vehil_uart_isr, "ax", @progbits

; A received byte into the RX ring; a full ring or a byte the hardware lost
; (DOR0, read before UDR0) counts an overrun (saturating at 0xFFFF).
        .global USART0_RX_vect
USART0_RX_vect:
        push    r24
        in      r24, _SFR_IO_ADDR(SREG)
        push    r24
        push    r30
        push    r31
        lds     r24, _SFR_MEM_ADDR(UCSR0A)
        sbrc    r24, DOR0
        rjmp    lost
take:   lds     r24, _SFR_MEM_ADDR(UDR0)
        lds     r30, uart_rx_head
        ldi     r31, hi8(uart_rx_buf)
        st      Z, r24                  ; the slot at head is always free
        inc     r30
        lds     r24, uart_rx_tail
        cp      r30, r24
        breq    full                    ; full: the byte is dropped
        sts     uart_rx_head, r30
rx_out: pop     r31
        pop     r30
        pop     r24
        out     _SFR_IO_ADDR(SREG), r24
        pop     r24
        reti
lost:   rcall   count                   ; the hardware lost the byte before this one
        rjmp    take
full:   rcall   count
        rjmp    rx_out
count:  lds     r30, uart_rx_lost
        lds     r31, uart_rx_lost + 1
        adiw    r30, 1
        breq    1f                      ; already 0xFFFF
        sts     uart_rx_lost + 1, r31
        sts     uart_rx_lost, r30
1:      ret

; The next released byte from the TX ring; with none left, the interrupt turns
; itself off until uart_tx_close() releases more.
        .global USART0_UDRE_vect
USART0_UDRE_vect:
        push    r30
        push    r31
        in      r31, _SFR_IO_ADDR(SREG)
        push    r31
        lds     r30, uart_tx_tail
        lds     r31, uart_tx_head
        cp      r30, r31
        breq    idle
        ldi     r31, hi8(uart_tx_buf)
        ld      r31, Z
        sts     _SFR_MEM_ADDR(UDR0), r31
        inc     r30
        sts     uart_tx_tail, r30
tx_out: pop     r31
        out     _SFR_IO_ADDR(SREG), r31
        pop     r31
        pop     r30
        reti
idle:   lds     r31, _SFR_MEM_ADDR(UCSR0B)
        andi    r31, ~(1 << UDRIE0)
        sts     _SFR_MEM_ADDR(UCSR0B), r31
        rjmp    tx_out
