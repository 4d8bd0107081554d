; bfp24_dot and bfp24_band for the AVR build: sums of products of sign-magnitude words
; (bit 31 the sign, bits 0-23 the magnitude), exact in int64, as the C twins bfp24_dot_c
; and bfp24_band_c in bfp24.c. Each pair is the unsigned 24 × 24 product of nine hardware
; MULs (48 bits, exact), added to or subtracted from the sum by the signs' exclusive or:
; 76 cycles a pair (78 for a negative product), in a subroutine both share.
;
; avr-gcc's interface: bfp24_dot: a in r25:r24, b in r23:r22, n in r20; the sum in
; r25:r18. bfp24_band: r in r25:r24, c in r23:r22, rows in r20, out in r19:r18. Each saves
; what it uses of r2-r17, r28, r29; r1 is left 0.

#include "fixmath/fx_save_avr.inc"

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

; r25:r18 += Σ X[i] Z[i] over COUNT (> 0) pairs; X and Z move past them, COUNT ends 0.
; Uses r2-r8, r10-r15, r0, r1; ZERO is 0. A function symbol of its own, so that profiles
; name it.
        .type   bfp24_pairs, @function
bfp24_pairs:
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
        ret
3:      sub     r18, r10
        sbc     r19, r11
        sbc     r20, r12
        sbc     r21, r13
        sbc     r22, r14
        sbc     r23, r15
        sbc     r24, ZERO
        sbc     r25, ZERO
        rjmp    4b              ; (brne does not reach back to 1 from here)
        .size   bfp24_pairs, . - bfp24_pairs

; r9 is left out: bfp24_dot does not use it, bfp24_band saves it with Y
.macro SAVE
        PUSH_RANGE 2, 8, 10, 17
.endm

.macro RESTORE
        clr     r1
        POP_RANGE 2, 8, 10, 17
.endm

.macro CLEAR_SUM
        clr     r18
        clr     r19
        movw    r20, r18
        movw    r22, r18
        movw    r24, r18
.endm

        .global bfp24_dot
bfp24_dot:
        SAVE
        movw    r26, r24        ; X = a
        movw    r30, r22        ; Z = b
        mov     COUNT, r20
        clr     ZERO
        CLEAR_SUM
        tst     COUNT
        breq    9f
        rcall   bfp24_pairs
9:      RESTORE
        ret

; out[i] = Σ r[3 i + d] c[i + d] over d < min(3, rows - i): X = R c for a banded R, a
; row of three a call of bfp24_pairs, so none of bfp24_dot's per-call saving.
#define LEFT r9
        .global bfp24_band
bfp24_band:
        SAVE
        PUSH_RANGE 9, 9, 28, 29
        movw    r26, r24        ; X = r
        movw    r30, r22        ; Z = c
        movw    r28, r18        ; Y = out
        mov     LEFT, r20
        clr     ZERO
        tst     LEFT
        breq    8f
5:      CLEAR_SUM
        ldi     COUNT, 3        ; min(3, rows left)
        cp      LEFT, COUNT
        brsh    6f
        mov     COUNT, LEFT
6:      rcall   bfp24_pairs
        st      Y+, r18
        st      Y+, r19
        st      Y+, r20
        st      Y+, r21
        st      Y+, r22
        st      Y+, r23
        st      Y+, r24
        st      Y+, r25
        mov     r24, LEFT       ; Z back to the next row's c[i + 1], X on to its r
        cpi     r24, 3
        brlo    7f
        sbiw    r30, 8
        rjmp    4f
7:      sbiw    r30, 4          ; (two rows left: the last one's c; one: nothing follows)
        adiw    r26, 4
4:      dec     LEFT
        brne    5b
8:      POP_RANGE 9, 9, 28, 29
        RESTORE
        ret
