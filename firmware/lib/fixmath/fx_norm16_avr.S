; fx_norm16 for the AVR build: in[0..n) 2^-k rounded half up as int16 with |out| <= limit,
; as the C twin fx_norm16_c in fixmath.c (the same bits). The peak by compares, its bit
; length by bytes, then per entry (v + 2^(k-1)) >> k as a choice of bytes and a product by
; 2^(8 - bits) whose bytes are the result: ~29 cycles an entry, where avr-gcc's C took ~60.
;
; avr-gcc's interface: in in r25:r24, out in r23:r22, n in r20, limit in r19:r18; k in r24.
; Clobbers r0, r18-r27, r30, r31 (call-used) and saves r14-r17, r28, r29; r1 is left 0.

#include "fx_save_avr.inc"

        .section .text.fx_norm16, "ax", @progbits
        .global fx_norm16

; out[i] = the low 16 bits of (B2:B1:B0 m) >> 8, for the entry's bytes B0-B2 after the
; whole-byte shift (SIGN: B2 is B1's sign fill)
.macro  SHIFT_LOOP b0, b1, b2, sign
1:      ld      r18, X+
        ld      r19, X+
        ld      r20, X+
        ld      r21, X+
        add     r18, r14        ; + 2^(k-1)
        adc     r19, r15
        adc     r20, r16
        adc     r21, r17
        .if \sign
        mov     r25, \b1
        lsl     r25
        sbc     r25, r25
        mul     \b0, r28
        mov     r22, r1         ; B0 m's top
        mul     r25, r28
        .else
        mul     \b0, r28
        mov     r22, r1
        mul     \b2, r28
        .endif
        mov     r23, r0         ; B2 m's bottom
        mul     \b1, r28
        add     r22, r0
        adc     r23, r1
        st      Z+, r22
        st      Z+, r23
        dec     r29
        brne    1b
        rjmp    .Ldone
.endm

fx_norm16:
        PUSH_RANGE 14, 17, 28, 29
        movw    r28, r18        ; L = 2 limit + 1
        lsl     r28
        rol     r29
        ori     r28, 1
        movw    r26, r24        ; X = in
        clr     r14             ; the peak, r17:r14
        clr     r15
        movw    r16, r14
        mov     r21, r20
        tst     r21
        breq    .Lpeaked
.Lpeak:
        ld      r18, X+
        ld      r19, X+
        ld      r30, X+
        ld      r31, X+
        tst     r31
        brpl    2f
        com     r31             ; |v| as uint32 (2^31 for INT32_MIN)
        com     r30
        com     r19
        neg     r18
        sbci    r19, -1
        sbci    r30, -1
        sbci    r31, -1
2:      cp      r14, r18
        cpc     r15, r19
        cpc     r16, r30
        cpc     r17, r31
        brsh    3f
        movw    r14, r18
        movw    r16, r30
3:      dec     r21
        brne    .Lpeak
.Lpeaked:
        ; the bit length in r21, then k = it - 14
        ldi     r21, 32
        mov     r18, r17
        tst     r18
        brne    4f
        ldi     r21, 24
        mov     r18, r16
        tst     r18
        brne    4f
        ldi     r21, 16
        mov     r18, r15
        tst     r18
        brne    4f
        ldi     r21, 8
        mov     r18, r14
        tst     r18
        brne    4f
        clr     r21             ; zeros: k = 0
        rjmp    .Lup
4:      lsl     r18
        brcs    5f
        dec     r21
        rjmp    4b
5:      subi    r21, 14
        breq    .Lup
        brpl    .Ldown
.Lup:   ; k <= 0 (|in| < 2^14): out = in's low 16 bits << -k
        movw    r26, r24        ; X = in
        mov     r24, r21        ; k
        neg     r21
        movw    r30, r22        ; Z = out
        mov     r29, r20        ; the count
        tst     r29
        brne    6f
        rjmp    .Ldone
6:      ld      r18, X+
        ld      r19, X+
        adiw    r26, 2
        mov     r25, r21
        tst     r25
        breq    8f
7:      lsl     r18
        rol     r19
        dec     r25
        brne    7b
8:      st      Z+, r18
        st      Z+, r19
        dec     r29
        brne    6b
        rjmp    .Ldone
.Ldown: ; 1 <= k <= 16: rounding up would pass the limit when peak >= L 2^(k-1)
        movw    r26, r24        ; X = in
        mov     r24, r21        ; k
        mov     r18, r21
        dec     r18             ; k - 1
        ldi     r30, 1          ; 2^((k-1) & 7): 1 or 4, doubled, swapped
        sbrc    r18, 1
        ldi     r30, 4
        sbrc    r18, 0
        lsl     r30
        sbrc    r18, 2
        swap    r30
        mul     r28, r30        ; P = L 2^((k-1) & 7) in r31:r21:r25
        mov     r25, r0
        mov     r21, r1
        mul     r29, r30
        add     r21, r0
        clr     r31
        adc     r31, r1
        clr     r1
        sbrc    r18, 3
        rjmp    11f
        cp      r14, r25        ; peak >= P?
        cpc     r15, r21
        cpc     r16, r31
        cpc     r17, r1
        rjmp    12f
11:     cp      r14, r1         ; peak >= P 2^8?
        cpc     r15, r25
        cpc     r16, r21
        cpc     r17, r31
12:     brlo    13f
        inc     r24             ; k + 1
        inc     r18
13:     ; 2^((k-1) & 7) in r30 and m = 2^(7 - ((k-1) & 7)) in r28, as above
        ldi     r30, 1
        ldi     r28, 0x80
        sbrs    r18, 1
        rjmp    14f
        ldi     r30, 4
        ldi     r28, 0x20
14:     sbrs    r18, 0
        rjmp    15f
        lsl     r30
        lsr     r28
15:     sbrs    r18, 2
        rjmp    16f
        swap    r30
        swap    r28
16:
        clr     r14             ; half = 2^(k-1) in r17:r14
        clr     r15
        movw    r16, r14
        mov     r29, r20        ; the count
        sbrc    r18, 4
        rjmp    .Lbytes2
        sbrc    r18, 3
        rjmp    .Lbytes1
        mov     r14, r30
        movw    r30, r22        ; Z = out
        SHIFT_LOOP r18, r19, r20, 0
.Lbytes1:
        mov     r15, r30
        movw    r30, r22
        SHIFT_LOOP r19, r20, r21, 0
.Lbytes2:
        mov     r16, r30
        movw    r30, r22
        SHIFT_LOOP r20, r21, r25, 1
.Ldone:
        clr     r1
        POP_RANGE 14, 17, 28, 29
        ret
