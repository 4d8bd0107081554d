; fx_mul_f for the AVR build: a · (±m 2^-sh) for an int32 a and a constant factor kept as a
; 16-bit mantissa m and a shift 9 <= sh <= 47 (the factor's sign in sh's bit 7: fixmath.h's
; fx_factor_t), rounded to nearest with ties away from zero and saturated to int32 (flagged).
; |a| times m by the eight hardware products of its four bytes by m's two, then the shift:
; whole bytes by register moves, the rest bit by bit (at most seven), the last bit out
; rounding; then the sign. The C twin fx_mul_f_c in fixmath.c gives the same bits.
;
; avr-gcc's interface: a in r25:r22, m in r21:r20, sh in r18, status pointer in r17:r16;
; result in r25:r22. Clobbers r0, r18-r27, r30, r31 (call-used); r1 is left 0. No skip over
; a RET (QEMU 7.2 runs one wrong: see firmware/src/mulhisi3.S).

#define SATURATED 0x01          /* STATUS_SATURATED, proto/messages.h */

        .section .text.fx_mul_f_avr, "ax", @progbits
        .global fx_mul_f_avr
fx_mul_f_avr:
        mov     r0, r25         ; the result's sign, a's xor the factor's, kept in T
        eor     r0, r18
        bst     r0, 7
        andi    r18, 0x3f
        tst     r25             ; |a|, as unsigned: INT32_MIN gives 2^31
        brpl    1f
        com     r25
        com     r24
        com     r23
        neg     r22
        sbci    r23, 0xff
        sbci    r24, 0xff
        sbci    r25, 0xff
1:      clr     r26             ; P = |a| m < 2^47: P1 in r19, P2..P5 in r26, r27, r30, r31
        clr     r27
        mul     r22, r20        ; a0 m0: only its high byte reaches P1
        mov     r19, r1
        mul     r22, r21        ; a0 m1
        add     r19, r0
        adc     r26, r1
        mov     r22, r18        ; sh, now that a0 is used
        clr     r18             ; zero
        mul     r23, r20        ; a1 m0
        add     r19, r0
        adc     r26, r1
        adc     r27, r18
        mul     r23, r21        ; a1 m1: P1..P3 now hold a0..a1 times m, below 2^32
        add     r26, r0
        adc     r27, r1
        clr     r30
        clr     r31
        mul     r24, r20        ; a2 m0
        add     r26, r0
        adc     r27, r1
        adc     r30, r18
        mul     r24, r21        ; a2 m1
        add     r27, r0
        adc     r30, r1
        adc     r31, r18
        mul     r25, r20        ; a3 m0
        add     r27, r0
        adc     r30, r1
        adc     r31, r18
        mul     r25, r21        ; a3 m1
        add     r30, r0
        adc     r31, r1
        clr     r1
        subi    r22, 9          ; k = sh - 9: P >> 8 goes right by k + 1, the last bit rounding
        sbrs    r22, 5          ; k & 32
        rjmp    2f
        mov     r19, r31
        clr     r26
        clr     r27
        clr     r30
        clr     r31
2:      sbrs    r22, 4          ; k & 16
        rjmp    3f
        mov     r19, r27
        mov     r26, r30
        mov     r27, r31
        clr     r30
        clr     r31
3:      sbrs    r22, 3          ; k & 8
        rjmp    4f
        mov     r19, r26
        mov     r26, r27
        mov     r27, r30
        mov     r30, r31
        clr     r31
4:      andi    r22, 7
        breq    6f
5:      lsr     r31
        ror     r30
        ror     r27
        ror     r26
        ror     r19
        dec     r22
        brne    5b
6:      lsr     r31             ; the last bit: its carry rounds half up the magnitude
        ror     r30
        ror     r27
        ror     r26
        ror     r19
        adc     r19, r18
        adc     r26, r18
        adc     r27, r18
        adc     r30, r18
        adc     r31, r18
        tst     r31             ; the magnitude past 2^31 - 1?
        brne    8f
        sbrc    r30, 7
        rjmp    8f
7:      brtc    9f
        com     r30             ; negative: the magnitude negated
        com     r27
        com     r26
        neg     r19
        sbci    r26, 0xff
        sbci    r27, 0xff
        sbci    r30, 0xff
9:      mov     r22, r19
        mov     r23, r26
        mov     r24, r27
        mov     r25, r30
        ret
8:      brtc    10f             ; past it: exactly 2^31 is INT32_MIN when negative
        tst     r31
        brne    10f
        cpi     r30, 0x80
        brne    10f
        mov     r0, r27
        or      r0, r26
        or      r0, r19
        brne    10f
        rjmp    7b
10:     ldi     r19, 0xff       ; saturated: INT32_MAX, or INT32_MIN when negative
        ldi     r26, 0xff
        ldi     r27, 0xff
        ldi     r30, 0x7f
        brtc    11f
        ldi     r19, 0
        ldi     r26, 0
        ldi     r27, 0
        ldi     r30, 0x80
11:     mov     r22, r19
        mov     r23, r26
        mov     r24, r27
        mov     r25, r30
        movw    r30, r16
        ld      r18, Z
        ori     r18, SATURATED
        st      Z, r18
        ret
