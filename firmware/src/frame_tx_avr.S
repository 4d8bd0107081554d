; frame_tx_run() of firmware/lib/proto/frame.c in assembly: bytes of a frame into the
; UART's TX ring, COBS-encoded, with the CRC-32C run over them on the way. Every byte
; of every reply goes through this loop (~37 cycles a byte against ~50 in C). The C
; in frame.c is its twin on the host and gives the same bytes.
;
; uint8_t frame_tx_run(uint32_t *crc, uint8_t code, const uint8_t *data, uint8_t n)
; returns the COBS code of the block so far (1 + its bytes). A zero byte ends the
; block: its code goes into the placeholder (uart_tx_held) and the zero's place is
; the next block's placeholder, held back with the rest until uart_tx_close()
; releases the frame. No block reaches 254 bytes: frames are shorter (frame.c).

#include <avr/io.h>

#define N       r18
#define CODE    r19
#define CRC0    r20
#define CRC1    r21
#define CRC2    r22
#define CRC3    r23
#define W       r24     /* uart_tx_write, in a register while the loop runs */
#define ROOM    r25     /* bytes the ring can take before W meets the tail */
#define BYTE    r0

        .section .text.frame_tx_run, "ax", @progbits
        .global frame_tx_run
frame_tx_run:
        movw    r26, r20                ; X: the data
        mov     CODE, r22
        movw    r30, r24
        push    r30                     ; the CRC's address, for the end
        push    r31
        ld      CRC0, Z
        ldd     CRC1, Z+1
        ldd     CRC2, Z+2
        ldd     CRC3, Z+3
        lds     W, uart_tx_write
        rcall   room
        tst     N
        breq    done

next:   ld      BYTE, X+
        ; CRC-32C, as crc32c_update() in proto/crc32c.h
        mov     r30, CRC0
        eor     r30, BYTE
        ldi     r31, hi8(crc32c_planes)
        lpm     CRC0, Z
        eor     CRC0, CRC1
        inc     r31
        lpm     CRC1, Z
        eor     CRC1, CRC2
        inc     r31
        lpm     CRC2, Z
        eor     CRC2, CRC3
        inc     r31
        lpm     CRC3, Z
        ; COBS
        subi    ROOM, 1
        brcs    wait
store:  mov     r30, W
        ldi     r31, 0
        subi    r30, lo8(-(uart_tx_buf))
        sbci    r31, hi8(-(uart_tx_buf))
        tst     BYTE
        breq    zero                    ; the block ends: its code stands for this zero
        st      Z, BYTE
        inc     W
        inc     CODE
count:  dec     N
        brne    next

done:   sts     uart_tx_write, W
        pop     r31
        pop     r30
        st      Z, CRC0
        std     Z+1, CRC1
        std     Z+2, CRC2
        std     Z+3, CRC3
        mov     r24, CODE
        ret

; The ring is full: wait for the UDRE interrupt to drain what was released.
wait:   rcall   room
        subi    ROOM, 1
        brcs    wait
        rjmp    store

; The zero's place holds the next block's code; this block's goes where it was held.
zero:   st      Z, BYTE                 ; 0 until the block ends
        lds     r30, uart_tx_held
        sts     uart_tx_held, W
        ldi     r31, 0
        subi    r30, lo8(-(uart_tx_buf))
        sbci    r31, hi8(-(uart_tx_buf))
        st      Z, CODE
        inc     W
        ldi     CODE, 1
        rjmp    count

; ROOM = tail - W - 1: the bytes that fit before the ring is full.
room:   lds     ROOM, uart_tx_tail
        sub     ROOM, W
        dec     ROOM
        ret
