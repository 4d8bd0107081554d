; stlqf_normalize64 for the AVR build: n int64 values 2^-k, rounded half up, as int32 with
; |out| <= 2^27 - 1, as the C twin stlqf_normalize64_c in stlqf.c (the same bits). The
; magnitudes' OR byte by byte as each value streams in (its top byte read first for its
; sign), its bit length by bytes, then per value a choice of five bytes, at most seven bit
; shifts and the rounding, where avr-gcc called libgcc's 64-bit shift, compare and negate.
;
; avr-gcc's interface: in in r25:r24, out in r23:r22, n in r20; k in r24.
; Clobbers r0, r18-r27, r30, r31 (call-used) and saves r13-r17, r28, r29; r1 is left 0.

#include "fixmath/fx_save_avr.inc"

        .section .text.stlqf_normalize64, "ax", @progbits
        .global stlqf_normalize64

; P (r25:r18) |= |the int64 at X|, X advanced past it; r0 and r31 scratch, r1 = 0
.macro  OR_MAGNITUDE
        adiw    r26, 7
        ld      r0, X           ; the top byte: the sign
        sbiw    r26, 7
        tst     r0
        brmi    1f
        .irp    p, 18, 19, 20, 21, 22, 23, 24, 25
        ld      r0, X+
        or      r\p, r0
        .endr
        rjmp    2f
1:      clc                     ; -x = 0 - x, a byte at a time
        .irp    p, 18, 19, 20, 21, 22, 23, 24, 25
        ld      r0, X+
        mov     r31, r1
        sbc     r31, r0
        or      r\p, r31
        .endr
2:
.endm

stlqf_normalize64:
        PUSH_RANGE 13, 17, 28, 29
        movw    r28, r24        ; Y = in
        movw    r16, r22        ; out
        mov     r13, r20        ; n
        mov     r15, r20        ; the count
        movw    r26, r24        ; X = in
        clr     r18             ; P, the magnitudes' OR
        clr     r19
        movw    r20, r18
        movw    r22, r18
        movw    r24, r18
        rjmp    31f
30:     OR_MAGNITUDE
        dec     r15
31:     cpse    r15, r1         ; the loop's body is past a branch's reach
        rjmp    30b
        ldi     r30, 64         ; P's bit length: its top nonzero byte, then bits
        .irp    p, 25, 24, 23, 22, 21, 20, 19, 18
        mov     r0, r\p
        tst     r0
        brne    3f
        subi    r30, 8
        .endr
        rjmp    .Lup            ; zeros: k = 0 (r30), the values copied as k <= 0 does
3:      sbrc    r0, 7
        rjmp    4f
        lsl     r0
        dec     r30
        rjmp    3b
4:      subi    r30, 27         ; k
        breq    .Lup
        brpl    .Ldown
.Lup:   ; k <= 0: out = the low word << -k (-k <= 27)
        mov     r14, r30
        movw    r26, r28        ; X = in
        movw    r30, r16        ; Z = out
        mov     r15, r13
5:      tst     r15
        brne    6f
        rjmp    .Ldone
6:      ld      r18, X+
        ld      r19, X+
        ld      r20, X+
        ld      r21, X+
        adiw    r26, 4
        mov     r0, r14
        neg     r0
        sbrs    r0, 4
        rjmp    7f
        movw    r20, r18        ; << 16
        clr     r18
        clr     r19
7:      sbrs    r0, 3
        rjmp    8f
        mov     r21, r20        ; << 8
        mov     r20, r19
        mov     r19, r18
        clr     r18
8:      ldi     r22, 7
        and     r0, r22
        breq    10f
9:      lsl     r18
        rol     r19
        rol     r20
        rol     r21
        dec     r0
        brne    9b
10:     st      Z+, r18
        st      Z+, r19
        st      Z+, r20
        st      Z+, r21
        dec     r15
        rjmp    5b
.Ldown: ; k >= 1: y = x >> (k - 1) from x's bytes B..B+4 (B = (k - 1) >> 3, at most 4, the
        ; ninth byte x's sign fill) and (k - 1) & 7 bit shifts, out = (y >> 1) + (y & 1); T
        ; where |out| passed 2^27 - 1: then once more with k + 1
        mov     r14, r30
11:     movw    r26, r28        ; X = in
        movw    r30, r16        ; Z = out
        mov     r15, r13
        clt
12:     tst     r15
        brne    13f
        rjmp    19f
13:     .irp    p, 18, 19, 20, 21, 22, 23, 24, 25
        ld      r\p, X+
        .endr
        mov     r0, r14
        dec     r0              ; k - 1
        sbrs    r0, 5
        rjmp    14f
        movw    r18, r22        ; bytes 4..7 and the fill
        movw    r20, r24
        mov     r22, r25
        lsl     r22
        sbc     r22, r22
14:     sbrs    r0, 4
        rjmp    15f
        movw    r18, r20        ; bytes 2..7
        movw    r20, r22
        movw    r22, r24
15:     sbrs    r0, 3
        rjmp    16f
        mov     r18, r19        ; a byte more
        mov     r19, r20
        mov     r20, r21
        mov     r21, r22
        mov     r22, r23
16:     ldi     r23, 7
        and     r0, r23
        breq    18f
17:     asr     r22
        ror     r21
        ror     r20
        ror     r19
        ror     r18
        dec     r0
        brne    17b
18:     asr     r21             ; y >> 1, its low bit in C added back: the rounding
        ror     r20
        ror     r19
        ror     r18
        adc     r18, r1
        adc     r19, r1
        adc     r20, r1
        adc     r21, r1
        st      Z+, r18
        st      Z+, r19
        st      Z+, r20
        st      Z+, r21
        tst     r21             ; |out| > 2^27 - 1: out >= 2^27 or out < -(2^27 - 1)
        brmi    20f
        cpi     r21, 0x08
        brlo    21f
        set
        rjmp    21f
20:     ldi     r22, 0x01       ; out < 0xf8000001?
        cp      r18, r22
        cpc     r19, r1
        cpc     r20, r1
        ldi     r22, 0xf8
        cpc     r21, r22
        brsh    21f
        set
21:     dec     r15
        rjmp    12b
19:     brtc    .Ldone
        inc     r14             ; one bit more where rounding up reached 2^27
        rjmp    11b
.Ldone:
        mov     r24, r14
        POP_RANGE 13, 17, 28, 29
        ret
