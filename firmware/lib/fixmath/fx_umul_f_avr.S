; fx_umul_f for the AVR build: a · m · 2^-sh rounded half up, for a < 2^31, a 16-bit m and
; 16 <= sh <= 47 (fixmath.h's fx_ufactor_t). The eight hardware products of a's four bytes
; by m's two, then the shift: whole bytes by register moves, the rest bit by bit (at most
; seven), the last bit out rounding. The C twin in fixmath.h gives the same bits.
;
; avr-gcc's interface: a in r25:r22, m in r21:r20, sh in r18; result in r25:r22. Clobbers
; r0, r18-r27, r30, r31 (call-used); r1 is left 0. No skip over a RET.

#include "fx_mul32x16.inc"

        .section .text.fx_umul_f_avr, "ax", @progbits
        .global fx_umul_f_avr
fx_umul_f_avr:
        MUL32X16
        clr     r1
        subi    r22, 17         ; k = sh - 17: t = P >> 16 goes right by k + 1, rounded
        brcc    1f
        lsl     r19             ; sh = 16: t + P's bit 15
        rjmp    5f
1:      sbrs    r22, 4          ; k & 16
        rjmp    2f
        movw    r26, r30
        clr     r30
        clr     r31
2:      sbrs    r22, 3          ; k & 8
        rjmp    3f
        mov     r26, r27
        mov     r27, r30
        mov     r30, r31
        clr     r31
3:      andi    r22, 7
        breq    4f
6:      lsr     r31
        ror     r30
        ror     r27
        ror     r26
        dec     r22
        brne    6b
4:      lsr     r31             ; the last bit: its carry rounds half up
        ror     r30
        ror     r27
        ror     r26
5:      adc     r26, r18
        adc     r27, r18
        adc     r30, r18
        adc     r31, r18
        movw    r22, r26
        movw    r24, r30
        ret
