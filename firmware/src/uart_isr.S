; UART0's receive and transmit interrupts, in assembly: avr-gcc's versions save
; r0, r1 and RAMPZ and take ~60 cycles a byte each way; these save only what they
; use (49 and 41 cycles, call and return included). At 1 Mbaud a byte is 160 cycles,
; and every byte of every frame goes through one of them. The rings and their 8-bit
; indices are firmware/src/uart.c's; each ring is on a 256-byte boundary, so a slot's
; address is the ring's high byte and the index. The code that runs with interrupts
; off moves the bytes itself (UART_POLL, uart_poll.h): the idle loop below and the frame
; loops of frame_avr.S.

#include <avr/io.h>

#include "uart_poll.h"

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
lost:   rcall   uart_count_lost         ; the hardware lost the byte before this one
        rjmp    take
full:   rcall   uart_count_lost
        rjmp    rx_out
; The TX ring has run dry: the UDRE interrupt goes off, as it turns itself off, or it
; would run once, idle, when interrupts are next on (in a step). Uses r31; for UART_POLL.
        .global uart_tx_quiet
uart_tx_quiet:
        lds     r31, _SFR_MEM_ADDR(UCSR0B)
        andi    r31, ~(1 << UDRIE0)
        sts     _SFR_MEM_ADDR(UCSR0B), r31
        ret

; One more overrun (saturating at 0xFFFF). Uses Z; also called by UART_POLL.
        .global uart_count_lost
uart_count_lost:
        lds     r30, uart_rx_lost
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

; void uart_poll(void): UART_POLL for C, with interrupts off.
        .section .text.uart_poll, "ax", @progbits
        .global uart_poll
uart_poll:
        UART_POLL r24
        ret

; const uint8_t *uart_rx_wait(uint8_t *n): waits for received bytes, feeding the
; watchdog on every turn (a board kept busy by a full ring never idles here), and
; returns where they lie in the RX ring and in *n how many follow there without a
; wrap (the part after it comes next call). Interrupts are off while it waits: it
; moves the bytes itself, both ways, and its turn is 8 cycles, so a byte is taken or
; sent at most 8 cycles after the UART is ready. QEMU runs this loop ~30x slower, and
; so answers ~30x later, when it straddles a 256-byte flash page (a translation block
; ends at the boundary): it starts one.
        .section .text.uart_rx_wait, "ax", @progbits
        .p2align 8
        .global uart_rx_wait
uart_rx_wait:
        wdr                             ; on every call, whether it waits or not
        movw    r26, r24                ; X: n
        in      r18, _SFR_IO_ADDR(SREG)
        cli
        lds     r19, uart_rx_tail
        lds     r24, uart_rx_head
        cpse    r24, r19
        rjmp    got                     ; the RX interrupt left bytes in the ring
mask:   ldi     r20, _BV(RXC0)          ; what to wait for: a byte in, and room in UDR0
        lds     r30, uart_tx_tail       ; while released bytes wait to go out
        lds     r31, uart_tx_head
        cpse    r30, r31
        ori     r20, _BV(UDRE0)
1:      wdr
        sbic    _SFR_IO_ADDR(TIFR1), TOV1
        rcall   overflowed
        lds     r24, _SFR_MEM_ADDR(UCSR0A)
        and     r24, r20
        breq    1b
        UART_POLL r24
        lds     r24, uart_rx_head
        cpse    r24, r19
        rjmp    got
        rjmp    mask
got:    out     _SFR_IO_ADDR(SREG), r18
        cp      r19, r24
        brlo    2f                      ; tail < head: up to the head
        clr     r24                     ; else up to the ring's end
2:      sub     r24, r19
        st      X, r24
        mov     r24, r19
        ldi     r25, hi8(uart_rx_buf)
        ret

; Timer1 overflowed: counted here as its interrupt would (cycles.c), or a second
; overflow while the board idles would be lost from the cycle count.
overflowed:
        ldi     r24, _BV(TOV1)
        out     _SFR_IO_ADDR(TIFR1), r24  ; writing 1 clears it
        lds     r30, cycles_overflows
        lds     r31, cycles_overflows + 1
        adiw    r30, 1
        sts     cycles_overflows + 1, r31
        sts     cycles_overflows, r30
        ret
