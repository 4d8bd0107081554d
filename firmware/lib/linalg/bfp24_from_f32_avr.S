; bfp24_from_f32 for the AVR build: floats x[0..n) into a block m[0..n) with one exponent,
; the largest keeping its 24 bits, each truncated toward zero; returns the exponent
; (BFP24_NOT_FINITE for an infinity or a NaN). The C twin bfp24_from_f32_c in bfp24.c
; gives the same bits. Two passes: the largest biased exponent, then each mantissa moved
; down by whole bytes and bits (the second pass from the end, so no pointer is kept).
; ~40 cycles a float, then 5 for each bit moved.
;
; avr-gcc's interface: x in r25:r24, n in r22, m in r21:r20; the exponent in r25:r24.
; Uses only call-used registers; r1 is 0 on entry and left 0.

#define N r22
#define COUNT r23
#define TOP r24
#define T r25

        .section .text.bfp24_from_f32, "ax", @progbits
        .global bfp24_from_f32
bfp24_from_f32:
        movw    r26, r24        ; X = x
        movw    r30, r20        ; Z = m
        ldi     TOP, 1          ; zeros and subnormals are read at exponent 1
        mov     COUNT, N
        tst     COUNT
        brne    1f
        rjmp    4f
1:      adiw    r26, 2          ; the largest biased exponent
        ld      r20, X+
        ld      r21, X+
        lsl     r20
        rol     r21             ; the exponent
        cpi     r21, 0xFF
        brne    2f
        ldi     r24, lo8(0x4000) ; BFP24_NOT_FINITE
        ldi     r25, hi8(0x4000)
        ret
2:      cp      TOP, r21
        brsh    3f
        mov     TOP, r21
3:      dec     COUNT
        brne    1b
        mov     r0, N           ; Z = m + 4 n: the second pass goes back from the end
        clr     T
        lsl     r0
        rol     T
        lsl     r0
        rol     T
        add     r30, r0
        adc     r31, T
        mov     COUNT, N
5:      ld      r21, -X         ; the float's bytes from the top
        ld      r20, -X
        ld      r19, -X
        ld      r18, -X
        bst     r21, 7          ; T flag: the sign
        lsl     r20
        rol     r21             ; the exponent
        sec                     ; the hidden bit, unless a zero or a subnormal
        brne    6f
        inc     r21             ; (read at exponent 1)
        clc
6:      ror     r20
        mov     T, TOP          ; down by top - exponent
        sub     T, r21
        cpi     T, 24
        brlo    7f
        clr     r18             ; 24 or more: nothing left
        clr     r19
        clr     r20
        rjmp    10f
7:      cpi     T, 16
        brlo    8f
        mov     r18, r20
        clr     r19
        clr     r20
        subi    T, 16
        rjmp    9f
8:      cpi     T, 8
        brlo    9f
        mov     r18, r19
        mov     r19, r20
        clr     r20
        subi    T, 8
9:      tst     T               ; then bits
        breq    10f
        lsr     r20
        ror     r19
        ror     r18
        dec     T
        rjmp    9b
10:     clr     r21             ; the word, stored from its top: sign, magnitude
        bld     r21, 7
        st      -Z, r21
        st      -Z, r20
        st      -Z, r19
        st      -Z, r18
        dec     COUNT
        brne    5b
4:      clr     r25             ; top - 150
        subi    r24, 150
        sbci    r25, 0
        ret
