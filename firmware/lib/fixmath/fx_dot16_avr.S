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

; r25:r22 = the sum of the r20 pairs from X and Z (r21 = 0; r20 is used up): two pairs a
; loop, an odd count's first pair before it
.macro  DOT
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
2:
.endm

        .section .text.fx_dot16, "ax", @progbits
        .global fx_dot16
fx_dot16:
        PUSH_RANGE 16, 17
        movw    r26, r24        ; X = a
        movw    r30, r22        ; Z = b
        clr     r21             ; zero
        DOT
        clr     r1
        POP_RANGE 16, 17
        ret

; fx_dot16_rows: out[j] = (Σ a[i] b[j][i] over n pairs) >> shift for j < m, each sum as
; fx_dot16's, then shifted arithmetically: one call for a row of Gram sums, where a call
; per sum cost ~30 cycles more and the C loop around it ~45.
;
; avr-gcc's interface: a in r25:r24, b (m pointers) in r23:r22, out in r21:r20, m in r18,
; n in r16, shift (below 16) in r14. Clobbers r0, r18-r27, r30, r31 (call-used) and saves
; r8-r13, r16, r17, r28, r29; r1 is left 0.
        .section .text.fx_dot16_rows, "ax", @progbits
        .global fx_dot16_rows
fx_dot16_rows:
        PUSH_RANGE 8, 13, 16, 17, 28, 29
        movw    r12, r24        ; a
        movw    r28, r22        ; Y = b's pointers
        movw    r10, r20        ; out
        mov     r9, r18         ; columns left
        mov     r8, r16         ; n
        clr     r21             ; zero
        rjmp    8f
4:      ld      r30, Y+         ; Z = b[j]
        ld      r31, Y+
        movw    r26, r12        ; X = a
        mov     r20, r8
        DOT
        mov     r20, r14        ; >> shift: a whole byte first, then bits
        sbrs    r20, 3
        rjmp    5f
        mov     r22, r23
        mov     r23, r24
        mov     r24, r25
        lsl     r25
        sbc     r25, r25
5:      andi    r20, 7
        breq    7f
6:      asr     r25
        ror     r24
        ror     r23
        ror     r22
        dec     r20
        brne    6b
7:      movw    r30, r10        ; out[j]
        st      Z+, r22
        st      Z+, r23
        st      Z+, r24
        st      Z+, r25
        movw    r10, r30
        dec     r9
8:      cpse    r9, r21         ; the loop's body is past a branch's reach
        rjmp    4b
        clr     r1
        POP_RANGE 8, 13, 16, 17, 28, 29
        ret
