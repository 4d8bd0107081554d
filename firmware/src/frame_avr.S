; The loops of firmware/lib/proto/frame.c that every byte of every frame goes
; through, in assembly; the C in frame.c is their twin on the host and gives the
; same bytes. Both run the CRC-32C as crc32c_update() in proto/crc32c.h does.
;
; Where the UART's interrupts would cost more than a byte's time (uart.h,
; uart_frame_polled), both run a variant of their loop with interrupts off that
; serves the UART itself between bytes (UART_POLL, uart_serve.inc: the rings' indices
; in registers for the call); elsewhere the interrupts do, and the loops pay nothing
; for it.
;
; frame_rx_bytes() decodes a request from the RX ring (below): a block's data byte
; costs 30 cycles, 32 with the polled variant's service point every second byte.
;
; frame_tx_run() puts bytes of a frame into the UART's TX ring, COBS-encoded, with
; the CRC run over them on the way (36 cycles a byte, 40 with the polled variant's
; service point, ~49 in C).
;
; uint8_t frame_tx_run(uint32_t *crc, uint8_t code, const uint8_t *data, uint8_t n)
; returns the COBS code of the block so far (1 + its bytes). A zero byte ends the
; block: its code goes into the placeholder (uart_tx_held), the zero's place is the
; next block's placeholder, and everything before it is released to the UART (its
; UDRE interrupt, or the service points) there and then, so a reply starts out while
; the rest is encoded
; (uart_tx_close() releases the last block). No block reaches 254 bytes: frames are
; shorter (frame.c).

#include <avr/io.h>

#include "uart.h"
#include "uart_serve.inc"

#define N       r18
#define CODE    r19
#define CRC0    r20
#define CRC1    r21
#define CRC2    r22
#define CRC3    r23
#define W       r24     /* uart_tx_write, in a register while the loop runs */
#define ROOM    r25     /* bytes the ring can take before W meets the tail */
#define BYTE    r0

; One byte (BYTE) into the CRC (CRC0..CRC3), as crc32c_update() in proto/crc32c.h:
; 21 cycles. Uses Z. (vehil profile counts the CRC's cycles at the lines that use it.)
.macro CRC32C_BYTE
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
.endm

; To \polled, the polled variant, if the frame loops serve the UART
; (uart_frame_polled). Uses r0.
.macro IF_POLLED polled
        lds     r0, uart_frame_polled
        sbrc    r0, 0
        rjmp    \polled
.endm

; uint8_t frame_rx_bytes(frame_rx_t *rx, const uint8_t *data, uint8_t len,
;                        frame_status_t *st)
; proto/frame.c's receiver: COBS code bytes, data bytes, the delimiter and the frame's
; checks, the state in registers for the call. data lies in the RX ring (uart.c: its
; low byte is the ring's index), and the call takes the bytes that come in while it
; runs as well as the len given (up to the delimiter; at most the 255 the ring holds),
; so a request arriving while it is decoded is decoded to its end in one call, with no
; C between its blocks. Where the frame loops serve the UART (uart_frame_polled) it
; runs with interrupts off and serves it itself: the request's bytes come in through
; its service points, not the receive interrupt. Elsewhere SV_MASK is 0, so its
; service points never fire, and the head is read from RAM.
#define RAW_MAX 136     /* FRAME_RAW_MAX; the state (n, left, zero, status, crc,
                           crc_start) follows raw, 4 + RAW_MAX into frame_rx_t (frame.c) */
#define RX_STATE (4 + RAW_MAX)
#define LEFT    r18     /* data bytes left in the COBS block (0 after an error) */
#define FREE    r19     /* RAW_MAX - n */
#define K       r24
#define K0      r25
#define TOOK0   r10     /* data's ring index: the call took up to r26 */
#define END     r11     /* the ring's head, as last read */
#define STATUS  r12     /* FRAME_MORE while the frame is good so far */
; T: the block ends in an implied zero, emitted if the frame goes on (rx->zero).
; r6:r7: st; r8:r9: &rx->n; X: the next byte (r27 the ring's high byte, r26 its index).

; END = the ring's head: the service points' copy, or the interrupt's in RAM.
.macro RX_HEAD
        tst     SV_MASK
        breq    .Lram\@
        mov     END, SV_RXH
        rjmp    .Lgot\@
.Lram\@: lds    END, uart_rx_head
.Lgot\@:
.endm

        .section .text.frame_rx_bytes, "ax", @progbits
        .global frame_rx_bytes
frame_rx_bytes:
        push    r6
        push    r7
        push    r8
        push    r9
        push    r10
        push    r11
        push    r12
        push    r28
        push    r29
        movw    r6, r18
        movw    r26, r22
        mov     TOOK0, r26
        mov     END, r26
        movw    r30, r24
        subi    r30, lo8(-RX_STATE)
        sbci    r31, hi8(-RX_STATE)
        movw    r8, r30
        ld      FREE, Z                 ; n
        ldd     LEFT, Z+1
        ldd     r0, Z+2
        bst     r0, 0                   ; zero
        ldd     STATUS, Z+3
        ldd     CRC0, Z+4
        ldd     CRC1, Z+5
        ldd     CRC2, Z+6
        ldd     CRC3, Z+7
        movw    r28, r30                ; Y: raw + n
        subi    r28, lo8(RAW_MAX)
        sbci    r29, hi8(RAW_MAX)
        add     r28, FREE
        adc     r29, r1
        neg     FREE
        subi    FREE, -RAW_MAX
        IF_POLLED b_polled
        push    SV_MASK
        clr     SV_MASK                 ; the interrupts serve the UART
        rjmp    b_next
b_polled:
        POLLED_BEGIN
        rjmp    b_next
        SERVE_STUB b_serve, b_served    ; here: in reach of the branch to it
; A byte: the delimiter, a code byte, or a block's data.
b_next: UART_POLL b_serve, b_served
        cp      r26, END
        brne    1f
        RX_HEAD
        cp      r26, END
        brne    1f
        rjmp    b_more                  ; the ring is empty
1:      ld      BYTE, X
        inc     r26
        tst     BYTE
        breq    b_delim
        tst     LEFT
        breq    b_code
        tst     FREE
        breq    b_over
        dec     r26                     ; the block's data, from this byte on
        rjmp    b_data

; A code byte: the previous block's zero if the frame goes on, then this block.
b_code: tst     STATUS
        brne    b_next                  ; after an error, up to the delimiter
        mov     LEFT, BYTE
        dec     LEFT
        brtc    2f
        tst     FREE
        breq    b_over
        clr     BYTE
        CRC32C_BYTE
        st      Y+, BYTE
        dec     FREE
2:      set
        cpi     LEFT, 0xFE              ; code 0xFF: no zero after its block
        brne    b_next
        clt
        rjmp    b_next

b_over: ldi     K, 5                    ; FRAME_OVERSIZE: the rest dropped up to the delimiter
        mov     STATUS, K
        clr     LEFT
        rjmp    b_next

; The delimiter: the frame's verdict (as rx_end), then the next frame.
b_delim:
        tst     STATUS
        brne    b_end
        ldi     K, 2                    ; FRAME_IDLE: nothing before the delimiter
        cpi     FREE, RAW_MAX
        brne    3f
        tst     LEFT
        brne    3f
        brtc    b_verdict
3:      ldi     K, 3                    ; FRAME_BAD_COBS
        tst     LEFT
        brne    b_verdict
        ldi     K, 4                    ; FRAME_BAD_CRC: too short, CRC, or length field
        cpi     FREE, RAW_MAX - 8 + 1
        brsh    b_verdict
        cpi     CRC0, 0x38              ; CRC32C_RESIDUE
        brne    b_verdict
        cpi     CRC1, 0xB4
        brne    b_verdict
        cpi     CRC2, 0x98
        brne    b_verdict
        cpi     CRC3, 0xB7
        brne    b_verdict
        movw    r30, r8                 ; raw[3], the body's length
        subi    r30, lo8(RAW_MAX - 3)
        sbci    r31, hi8(RAW_MAX - 3)
        ld      r0, Z
        ldi     K0, RAW_MAX - 8
        sub     K0, FREE
        cp      r0, K0
        brne    b_verdict
        ldi     K, 1                    ; FRAME_OK
b_verdict:
        mov     STATUS, K
b_end:  movw    r30, r6
        st      Z, STATUS
        std     Z+1, r1
        movw    r30, r8                 ; the next frame: n, left, zero 0, FRAME_MORE,
        st      Z, r1                   ; the CRC where each frame's starts
        std     Z+1, r1
        std     Z+2, r1
        std     Z+3, r1
        ldd     CRC0, Z+8
        ldd     CRC1, Z+9
        ldd     CRC2, Z+10
        ldd     CRC3, Z+11
        rjmp    b_store

b_more: movw    r30, r6                 ; FRAME_MORE: the state kept for the next call
        st      Z, r1
        std     Z+1, r1
        movw    r30, r8
        ldi     K, RAW_MAX
        sub     K, FREE
        st      Z, K
        std     Z+1, LEFT
        clr     K
        bld     K, 0
        std     Z+2, K
        std     Z+3, STATUS
b_store:
        std     Z+4, CRC0
        std     Z+5, CRC1
        std     Z+6, CRC2
        std     Z+7, CRC3
        tst     SV_MASK
        brne    4f
        pop     SV_MASK
        rjmp    5f
4:      POLLED_END
5:      mov     r24, r26
        sub     r24, TOOK0
        pop     r29
        pop     r28
        pop     r12
        pop     r11
        pop     r10
        pop     r9
        pop     r8
        pop     r7
        pop     r6
        ret

; A block's data: K0 = as many as the block, the frame's room and the ring hold, each
; copied with the CRC run over it (30 cycles, a service point every second byte: ~64
; apart); a zero ends the block early, for b_next to take as the delimiter. Written
; out: in a macro or a .rept, vehil profile would no longer find the CRC's lines by
; CRC32C_BYTE.
        SERVE_STUB d_serve, d_served
b_data: mov     K0, END
        sub     K0, r26
        cp      LEFT, K0
        brsh    6f
        mov     K0, LEFT
6:      cp      FREE, K0
        brsh    7f
        mov     K0, FREE
7:      mov     K, K0
d_next: UART_POLL d_serve, d_served
        ld      BYTE, X
        inc     r26
        tst     BYTE
        breq    d_zero
        CRC32C_BYTE
        st      Y+, BYTE
        dec     K
        breq    d_done
        ld      BYTE, X
        inc     r26
        tst     BYTE
        breq    d_zero
        CRC32C_BYTE
        st      Y+, BYTE
        dec     K
        brne    d_next
d_done: sub     K0, K
        sub     LEFT, K0
        sub     FREE, K0
        rjmp    b_next
d_zero: dec     r26                     ; the zero: b_next's
        rjmp    d_done

; A byte (BYTE) into the TX ring at W, COBS-encoded; to \zero if it is a zero.
.macro TX_STORE zero
        mov     r30, W
        ldi     r31, hi8(uart_tx_buf)   ; on a 256-byte boundary (uart.c)
        tst     BYTE
        breq    \zero                   ; the block ends: its code stands for this zero
        st      Z, BYTE
        inc     W
        inc     CODE
.endm

; The zero's place holds the next block's code; this block's goes where it was held,
; and the bytes up to the new placeholder go out. Interrupts off between the release
; and UDRIE0 on: the UDRE interrupt may send every released byte and turn itself off
; in between, and it must not come on again with nothing to send.
.macro TX_ZERO
        st      Z, BYTE                 ; 0 until the block ends
        lds     r30, uart_tx_held
        sts     uart_tx_held, W
        st      Z, CODE
        in      r31, _SFR_IO_ADDR(SREG)
        cli
        sts     uart_tx_head, W
        ldi     r30, UART_UCSR0B_ON | (1 << UDRIE0)
        sts     _SFR_MEM_ADDR(UCSR0B), r30
        out     _SFR_IO_ADDR(SREG), r31
        inc     W
        ldi     CODE, 1
.endm

; TX_ZERO in a polled variant: the ring's head and the UDRE interrupt's enable are in
; registers (uart_serve.inc), and the interrupts are off.
.macro TX_ZERO_POLLED
        st      Z, BYTE
        lds     r30, uart_tx_held
        sts     uart_tx_held, W
        st      Z, CODE
        mov     SV_TXH, W
        ori     SV_MASK, _BV(UDRE0)
        inc     W
        ldi     CODE, 1
.endm

; Pieces of frame_tx_frame's two variants (and frame_tx_crc's CRC_OUT_BYTE): to \wait unless ROOM holds the
; frame (n + 6 slots); the placeholder; the CRC inverted (CRC32C_XOROUT); its next byte
; into BYTE; the delimiter and the last block's code.
.macro FRAME_FITS wait
        subi    ROOM, 6
        brcs    \wait
        cp      ROOM, N
        brcs    \wait
.endm

.macro TX_PLACEHOLDER
        sts     uart_tx_held, W
        mov     r30, W
        ldi     r31, hi8(uart_tx_buf)
        st      Z, r1
        inc     W
        ldi     CODE, 1
.endm

.macro CRC_XOROUT
        com     CRC0
        com     CRC1
        com     CRC2
        com     CRC3
.endm

.macro CRC_OUT_BYTE
        mov     BYTE, CRC0
        mov     CRC0, CRC1
        mov     CRC1, CRC2
        mov     CRC2, CRC3
.endm

.macro TX_DELIMIT
        mov     r30, W                  ; the delimiter, released with the last block
        ldi     r31, hi8(uart_tx_buf)
        st      Z, r1
        inc     W
        lds     r30, uart_tx_held       ; the last block's code
        st      Z, CODE
        sts     uart_tx_write, W
.endm

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
        IF_POLLED tx_polled

next:   ld      BYTE, X+
        CRC32C_BYTE
        ; COBS
        subi    ROOM, 1
        brcs    wait
store:  TX_STORE zero
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

zero:   TX_ZERO
        rjmp    count

; The loop above with a service point a byte and in the wait for room (where r0 holds
; the byte to store: that stub moves its bytes through ROOM, which the wait recomputes).
tx_polled:
        POLLED_BEGIN
        rjmp    p_next
        SERVE_STUB tx_serve, tx_served  ; here: in reach of the loop's branches
p_next: UART_POLL tx_serve, tx_served
        ld      BYTE, X+
        CRC32C_BYTE
        subi    ROOM, 1
        brcs    p_wait
p_store: TX_STORE p_zero
p_count: dec    N
        brne    p_next
        POLLED_END
        rjmp    done

p_wait: UART_POLL wait_serve, wait_served
        mov     ROOM, SV_TXT            ; the room, as room does
        sub     ROOM, W
        dec     ROOM
        subi    ROOM, 1
        brcs    p_wait
        rjmp    p_store

p_zero: TX_ZERO_POLLED
        rjmp    p_count

        SERVE_STUB wait_serve, wait_served, ROOM

; uint8_t frame_tx_crc(uint32_t crc, uint8_t code) puts the CRC's four bytes, low first,
; into the TX ring, COBS-encoded as frame_tx_run's bytes are but not run through the
; CRC; returns the block's code (~16 cycles a byte, ~40 in C). It runs with the
; interrupts (the UDRE interrupt drains a full ring), at every rate.
        .global frame_tx_crc
frame_tx_crc:
        mov     CODE, r20
        movw    CRC0, r22               ; CRC0..CRC3: the bytes, the next one in CRC0
        movw    CRC2, r24
        lds     W, uart_tx_write
        rcall   room
        ldi     N, 4
c_next: CRC_OUT_BYTE
        subi    ROOM, 1
        brcs    c_wait
c_store: TX_STORE c_zero
c_count: dec    N
        brne    c_next
        sts     uart_tx_write, W
        mov     r24, CODE
        ret

c_wait: rcall   room
        subi    ROOM, 1
        brcs    c_wait
        rjmp    c_store

c_zero: TX_ZERO
        rjmp    c_count

; void frame_tx_frame(uint8_t answers, const uint8_t *data, uint8_t n): a whole frame
; whose header and body lie in data, as proto/frame.c's C (frame_tx_frame's twin) sends
; it: the placeholder, the bytes, the CRC's, the delimiter, released, in one call. It
; waits once for the ring to hold the whole frame (n + 6 slots: the placeholder, a slot
; a byte or its zero, the CRC's four, the delimiter), so its bytes go in unchecked.
; Where the frame loops serve the UART (uart_frame_polled), the service points run
; throughout, one every second byte (~72 cycles apart: UDR0 takes a byte every 80 at
; 2 Mbaud, the receiver holds three): no C and no interrupt from the first byte to the
; release.
        .section .text.frame_tx_frame, "ax", @progbits
        .global frame_tx_frame
frame_tx_frame:
        movw    r26, r22                ; X: the data
        mov     N, r20
        mov     BYTE, r24               ; the CRC starts over the answered type
        ldi     CRC0, 0xFF
        ldi     CRC1, 0xFF
        ldi     CRC2, 0xFF
        ldi     CRC3, 0xFF
        CRC32C_BYTE
        IF_POLLED f_polled
        lds     W, uart_tx_write
g_room: rcall   room
        FRAME_FITS g_room
        TX_PLACEHOLDER
        tst     N
        breq    g_crc
g_next: ld      BYTE, X+
        CRC32C_BYTE
        TX_STORE g_zero
g_count: dec    N
        brne    g_next
g_crc:  CRC_XOROUT
        ldi     N, 4
g_cnext: CRC_OUT_BYTE
        TX_STORE g_czero
g_ccount: dec   N
        brne    g_cnext
        TX_DELIMIT                      ; and out, as uart_tx_close()
        in      r31, _SFR_IO_ADDR(SREG)
        cli
        sts     uart_tx_head, W
        lds     r30, _SFR_MEM_ADDR(UCSR0A)
        ori     r30, _BV(TXC0)          ; writing 1 clears it: "these bytes are out"
        sts     _SFR_MEM_ADDR(UCSR0A), r30
        ldi     r30, UART_UCSR0B_ON | (1 << UDRIE0)
        sts     _SFR_MEM_ADDR(UCSR0B), r30
        out     _SFR_IO_ADDR(SREG), r31
        ret
g_zero: TX_ZERO
        rjmp    g_count
g_czero: TX_ZERO
        rjmp    g_ccount

; The same with a service point a byte, interrupts off.
f_polled:
        POLLED_BEGIN
        rjmp    f_room
        SERVE_STUB f_rserve, f_rserved  ; each stub in reach of the branch to it
f_room: UART_POLL f_rserve, f_rserved
        lds     W, uart_tx_write
        mov     ROOM, SV_TXT
        sub     ROOM, W
        dec     ROOM
        FRAME_FITS f_room
        TX_PLACEHOLDER
        rjmp    f_first
        SERVE_STUB f_serve, f_served
f_next: UART_POLL f_serve, f_served    ; every second byte, ~72 cycles apart
        ld      BYTE, X+
        CRC32C_BYTE
        TX_STORE f_zero
f_count: dec    N
        breq    f_crc
        ld      BYTE, X+
        CRC32C_BYTE
        TX_STORE f_zero2
f_count2: dec   N
        brne    f_next
        rjmp    f_crc
f_zero: TX_ZERO_POLLED
        rjmp    f_count
f_zero2: TX_ZERO_POLLED
        rjmp    f_count2
f_first: tst    N
        breq    f_crc
        rjmp    f_next
f_crc:  CRC_XOROUT
        ldi     N, 4
        rjmp    f_cnext
        SERVE_STUB f_cserve, f_cserved
f_cnext: UART_POLL f_cserve, f_cserved
        CRC_OUT_BYTE
        TX_STORE f_czero
f_ccount: dec   N
        brne    f_cnext
        rjmp    f_end
f_czero: TX_ZERO_POLLED
        rjmp    f_ccount
f_end:  TX_DELIMIT                      ; and out, as uart_tx_close()
        mov     SV_TXH, W
        ori     SV_MASK, _BV(UDRE0)
        lds     r30, _SFR_MEM_ADDR(UCSR0A)
        ori     r30, _BV(TXC0)          ; writing 1 clears it: "these bytes are out"
        sts     _SFR_MEM_ADDR(UCSR0A), r30
        POLLED_END
        ret

; ROOM = tail - W - 1: the bytes that fit before the ring is full.
room:   lds     ROOM, uart_tx_tail
        sub     ROOM, W
        dec     ROOM
        ret
