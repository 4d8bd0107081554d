; fx_band16 for the AVR build: out[i] = Σ band[i][d] c[i + d] over d < 3 and i + d < n, int16
; products summed in int32 (modulo 2^32, as the C twin fx_band16_c in fixmath.c). The
; window c[i..i+2] slides in registers (one load a row) and each product is four hardware
; multiplies added where their bytes fall: ~94 cycles a row, where avr-gcc's C took ~130.
;
; avr-gcc's interface: band in r25:r24 (three words a row), c in r23:r22, out in r21:r20,
; n in r18. Clobbers r0, r18-r27, r30, r31 (call-used) and saves r12-r17, r28, r29; r1 is
; left 0.

#include "fx_save_avr.inc"

        .section .text.fx_band16, "ax", @progbits
        .global fx_band16

; acc (r25:r22) += the cross terms of r17:r16 × r19:r18, signed (r21 = 0)
.macro  CROSS
        mulsu   r17, r18        ; at byte 1: C is its sign, its fill at byte 3 -1
        sbc     r25, r21
        add     r23, r0
        adc     r24, r1
        adc     r25, r21
        mulsu   r19, r16
        sbc     r25, r21
        add     r23, r0
        adc     r24, r1
        adc     r25, r21
.endm

; acc (r25:r22) += r17:r16 × r19:r18, signed
.macro  MAC
        mul     r16, r18
        add     r22, r0
        adc     r23, r1
        adc     r24, r21
        adc     r25, r21
        muls    r17, r19
        add     r24, r0
        adc     r25, r1
        CROSS
.endm

fx_band16:
        PUSH_RANGE 12, 17, 28, 29
        movw    r30, r24        ; Z = band
        movw    r26, r22        ; X = c
        movw    r28, r20        ; Y = out
        mov     r20, r18        ; rows left
        clr     r21             ; zero
        tst     r20
        brne    2f
        rjmp    .Ldone
2:      ld      r14, X+         ; c0
        ld      r15, X+
        clr     r12             ; c1 (0 past the end)
        clr     r13
        cpi     r20, 2
        brlo    .Lrow
        ld      r12, X+
        ld      r13, X+
.Lrow:
        ld      r16, Z+         ; band[i][0] c[i]: the sum's first product
        ld      r17, Z+
        movw    r18, r14
        muls    r17, r19
        movw    r24, r0
        mul     r16, r18
        movw    r22, r0
        CROSS
        ld      r16, Z+         ; band[i][1] c[i + 1]
        ld      r17, Z+
        movw    r18, r12
        MAC
        ld      r16, Z+         ; band[i][2] c[i + 2]
        ld      r17, Z+
        clr     r18
        clr     r19
        cpi     r20, 3
        brlo    1f
        ld      r18, X+
        ld      r19, X+
1:      movw    r14, r12        ; the window slides
        movw    r12, r18
        MAC
        st      Y+, r22
        st      Y+, r23
        st      Y+, r24
        st      Y+, r25
        dec     r20
        breq    .Ldone
        rjmp    .Lrow
.Ldone:
        clr     r1
        POP_RANGE 12, 17, 28, 29
        ret
