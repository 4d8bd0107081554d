; fx_dot16 for the AVR build: Σ a[i] b[i] over n int16 pairs, summed in int32 (modulo
; 2^32, as the C twin fx_dot16_c in fixmath.c; the callers keep the sum in range). Each
; product is four hardware multiplies added into the sum where their bytes fall, two pairs
; a loop: about 33 cycles a pair, where a call to libgcc's 16 × 16 product per pair costs
; ~50.
;
; avr-gcc's interface: a in r25:r24, b in r23:r22, n in r20; the sum in r25:r22.
; Clobbers r0, r18-r21, r26, r27, r30, r31 (call-used) and saves r16, r17; r1 is left 0.

#include "fx_save_avr.inc"

.macro  PAIR
        ld      r18, X+         ; a low, high
        ld      r19, X+
        ld      r16, Z+         ; b low, high
        ld      r17, Z+
        mul     r18, r16        ; a_l b_l, unsigned, at byte 0
        add     r22, r0
        adc     r23, r1
        adc     r24, r21
        adc     r25, r21
        muls    r19, r17        ; a_h b_h, signed, at byte 2
        add     r24, r0
        adc     r25, r1
        mulsu   r19, r16        ; a_h b_l, signed, at byte 1: C is its sign
        sbc     r25, r21        ; its sign fill at byte 3 is -1 when negative
        add     r23, r0
        adc     r24, r1
        adc     r25, r21
        mulsu   r17, r18        ; b_h a_l, the same
        sbc     r25, r21
        add     r23, r0
        adc     r24, r1
        adc     r25, r21
.endm

        .section .text.fx_dot16, "ax", @progbits
        .global fx_dot16
fx_dot16:
        PUSH_RANGE 16, 17
        movw    r26, r24        ; X = a
        movw    r30, r22        ; Z = b
        clr     r21             ; zero
        clr     r22             ; the sum, r25:r22
        clr     r23
        movw    r24, r22
        sbrs    r20, 0
        rjmp    3f              ; an even count: the loop of two pairs (none for 0)
        PAIR                    ; an odd one: one pair first
        dec     r20
3:      tst     r20
        breq    2f
1:      PAIR
        PAIR
        subi    r20, 2
        brne    1b
2:      clr     r1
        POP_RANGE 16, 17
        ret
