; fx_dot16x32_q15 for the AVR build: Σ l[k stride] y[k] for k < n (int16 l, int32 y) summed
; exactly in 56 bits, then rounded half up to 2^-15 and saturated to int32 (flagged): the
; C twin fx_dot16x32_q15_c in fixmath.c gives the same bits. Each product is the unsigned
; 16 × 32 of the hardware MUL added into the sum byte by byte, then corrected for a
; negative operand; ~85 cycles a pair.
;
; avr-gcc's interface: l in r25:r24, y in r23:r22, n in r20, stride (in int16s) in r18,
; status pointer in r17:r16; result in r25:r22. Saves what it uses of r2-r17, r28, r29.

#define SATURATED 0x01          /* STATUS_SATURATED, proto/messages.h */
#define ZERO r9

#include "fx_save_avr.inc"

; acc (r2..r8) += r1:r0 at byte b
.macro ACC_ADD b
        add     2+\b, r0
        adc     3+\b, r1
        .set    j, 4+\b
        .rept   5-\b
        adc     j, ZERO
        .set    j, j+1
        .endr
.endm

        .section .text.fx_dot16x32_q15, "ax", @progbits
        .global fx_dot16x32_q15
fx_dot16x32_q15:
        PUSH_RANGE 2, 9, 16, 17, 28, 29
        movw    r28, r16        ; status
        movw    r26, r24        ; X = l
        movw    r30, r22        ; Z = y
        lsl     r18             ; the stride in bytes, less the two read
        subi    r18, 2
        clr     ZERO
        clr     r2
        clr     r3
        movw    r4, r2
        movw    r6, r2
        clr     r8
        tst     r20
        brne    1f
        rjmp    3f
1:      ld      r16, X+         ; l
        ld      r17, X+
        add     r26, r18
        adc     r27, ZERO
        ld      r19, Z+         ; y
        ld      r21, Z+
        ld      r22, Z+
        ld      r23, Z+
        mul     r16, r19
        ACC_ADD 0
        mul     r16, r21
        ACC_ADD 1
        mul     r17, r19
        ACC_ADD 1
        mul     r16, r22
        ACC_ADD 2
        mul     r17, r21
        ACC_ADD 2
        mul     r16, r23
        ACC_ADD 3
        mul     r17, r22
        ACC_ADD 3
        mul     r17, r23
        add     r6, r0
        adc     r7, r1
        adc     r8, ZERO
        tst     r17             ; l < 0: less y 2^16 (y as unsigned)
        brpl    2f
        sub     r4, r19
        sbc     r5, r21
        sbc     r6, r22
        sbc     r7, r23
        sbc     r8, ZERO
        tst     r23             ; both < 0: plus 2^48
        brpl    2f
        inc     r8
2:      tst     r23             ; y < 0: less l 2^32 (l as unsigned)
        brpl    4f
        sub     r6, r16
        sbc     r7, r17
        sbc     r8, ZERO
4:      dec     r20
        breq    3f
        rjmp    1b
3:      ldi     r16, 0x40       ; + 2^14, then bits 15..46 are the result
        add     r3, r16
        adc     r4, ZERO
        adc     r5, ZERO
        adc     r6, ZERO
        adc     r7, ZERO
        adc     r8, ZERO
        lsl     r3
        rol     r4
        rol     r5
        rol     r6
        rol     r7
        rol     r8
        movw    r22, r4         ; the result, bytes 2..5 of the sum doubled
        movw    r24, r6
        mov     r16, r25        ; byte 6 must be the result's sign fill
        lsl     r16
        sbc     r16, r16
        cp      r8, r16
        breq    5f
        mov     r16, r8         ; saturated: by the sum's sign
        lsl     r16
        sbc     r16, r16
        mov     r22, r16
        com     r22
        mov     r23, r22
        mov     r24, r22
        ldi     r25, 0x7f
        eor     r25, r16
        ld      r16, Y
        ori     r16, SATURATED
        st      Y, r16
5:      clr     r1
        POP_RANGE 2, 9, 16, 17, 28, 29
        ret
