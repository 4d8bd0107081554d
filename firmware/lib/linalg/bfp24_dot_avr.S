; bfp24_dot for the AVR build: Σ a[i] b[i] over n sign-magnitude words (bit 31 the sign,
; bits 0-23 the magnitude), exact in int64, as the C twin bfp24_dot_c in bfp24.c. Each
; pair is the unsigned 24 × 24 product of nine hardware MULs (48 bits, exact), added to
; or subtracted from the sum by the signs' exclusive or: 76 cycles a pair (78 for a
; negative product).
;
; avr-gcc's interface: a in r25:r24, b in r23:r22, n in r20; the sum in r25:r18.
; Saves what it uses of r2-r17; r1 is left 0.

#define ZERO r16
#define COUNT r17
#define SIGN r8

; the product (r15:r10) += r1:r0 at byte b, the carry up to its top byte
.macro PROD_ADD b
        add     10+\b, r0
        adc     11+\b, r1
        .set    j, 12+\b
        .rept   4-\b
        adc     j, ZERO
        .set    j, j+1
        .endr
.endm

        .section .text.bfp24_dot, "ax", @progbits
        .global bfp24_dot
bfp24_dot:
        push    r2
        push    r3
        push    r4
        push    r5
        push    r6
        push    r7
        push    r8
        push    r10
        push    r11
        push    r12
        push    r13
        push    r14
        push    r15
        push    r16
        push    r17
        movw    r26, r24        ; X = a
        movw    r30, r22        ; Z = b
        mov     COUNT, r20
        clr     ZERO
        clr     r18             ; the sum, r25:r18
        clr     r19
        movw    r20, r18
        movw    r22, r18
        movw    r24, r18
        tst     COUNT
        brne    1f
        rjmp    9f
1:      ld      r2, X+          ; a's magnitude, r4:r2, and sign byte
        ld      r3, X+
        ld      r4, X+
        ld      SIGN, X+
        ld      r5, Z+          ; b's, r7:r5
        ld      r6, Z+
        ld      r7, Z+
        ld      r10, Z+
        eor     SIGN, r10       ; bit 7: the product's sign
        mul     r2, r5          ; a0 b0 at byte 0, a1 b1 at 2, a2 b2 at 4
        movw    r10, r0
        mul     r3, r6
        movw    r12, r0
        mul     r4, r7
        movw    r14, r0
        mul     r2, r6          ; the cross terms
        PROD_ADD 1
        mul     r3, r5
        PROD_ADD 1
        mul     r2, r7
        PROD_ADD 2
        mul     r4, r5
        PROD_ADD 2
        mul     r3, r7
        PROD_ADD 3
        mul     r4, r6
        PROD_ADD 3
        sbrc    SIGN, 7
        rjmp    3f
        add     r18, r10
        adc     r19, r11
        adc     r20, r12
        adc     r21, r13
        adc     r22, r14
        adc     r23, r15
        adc     r24, ZERO
        adc     r25, ZERO
4:      dec     COUNT
        brne    1b
        rjmp    9f
3:      sub     r18, r10
        sbc     r19, r11
        sbc     r20, r12
        sbc     r21, r13
        sbc     r22, r14
        sbc     r23, r15
        sbc     r24, ZERO
        sbc     r25, ZERO
        rjmp    4b              ; (brne does not reach back to 1 from here)
9:      clr     r1
        pop     r17
        pop     r16
        pop     r15
        pop     r14
        pop     r13
        pop     r12
        pop     r11
        pop     r10
        pop     r8
        pop     r7
        pop     r6
        pop     r5
        pop     r4
        pop     r3
        pop     r2
        ret
