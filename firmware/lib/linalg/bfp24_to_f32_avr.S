; bfp24_to_f32 for the AVR build: s 2^e (int64 s, int16 e) rounded to nearest-even float32,
; ±inf past FLT_MAX, ±0 below FLT_MIN, as the C twin bfp24_to_f32_c in bfp24.c: the
; magnitude's top byte moved into r25 a byte at a time, then its top bit a bit at a time;
; r25:r23 is the mantissa, r22's top bit the rounding bit, the rest sticky. ~60-110 cycles.
;
; avr-gcc's interface: s in r25:r18, e in r17:r16; the float in r25:r22. Uses only
; call-used registers (e is copied); r1 is 0 on entry and left 0.

#include "bfp24_neg64.inc"

#define EL r26
#define EH r27

        .section .text.bfp24_to_f32, "ax", @progbits
        .global bfp24_to_f32
bfp24_to_f32:
        movw    EL, r16         ; e, then the exponent of r25:r18's unit, less 40
        bst     r25, 7          ; T: the sign
        brtc    1f
        NEG64                   ; the magnitude: -s
1:      ldi     r30, 8          ; bytes left to move up
2:      tst     r25             ; the top byte into r25
        brne    3f
        mov     r25, r24
        mov     r24, r23
        mov     r23, r22
        mov     r22, r21
        mov     r21, r20
        mov     r20, r19
        mov     r19, r18
        clr     r18
        sbiw    EL, 8
        dec     r30
        brne    2b
        clr     r22             ; s = 0: +0
        clr     r23
        movw    r24, r22
        ret
3:      sbrc    r25, 7          ; its top bit into bit 7 (r20 and below are sticky only)
        rjmp    4f
        lsl     r21
        rol     r22
        rol     r23
        rol     r24
        rol     r25
        sbiw    EL, 1
        rjmp    3b
4:      sbrs    r22, 7          ; the rounding bit
        rjmp    6f
        andi    r22, 0x7F       ; to nearest: up if anything below it, or r23 odd
        or      r22, r21
        or      r22, r20
        or      r22, r19
        or      r22, r18
        brne    5f
        sbrs    r23, 0
        rjmp    6f
5:      subi    r23, 0xFF       ; the mantissa + 1
        sbci    r24, 0xFF
        sbci    r25, 0xFF
        brne    6f
        ldi     r25, 0x80       ; past 2^24: 2^23 one exponent up
        adiw    EL, 1
6:      subi    EL, lo8(-190)   ; the biased exponent: r25:r23 2^(e + 40), 150 + 40
        sbci    EH, hi8(-190)
        brmi    8f              ; below 0: ±0
        tst     EH
        brne    9f              ; past 255: ±inf
        tst     EL
        breq    8f
        cpi     EL, 0xFF
        breq    9f
        mov     r22, r23        ; the float: mantissa, exponent, sign
        mov     r23, r24
        mov     r24, r25
        lsl     r24             ; (the hidden bit out)
        lsr     EL
        ror     r24             ; the exponent's low bit in
        mov     r25, EL
        bld     r25, 7
        ret
8:      clr     r22
        clr     r23
        clr     r24
        clr     r25
        bld     r25, 7
        ret
9:      clr     r22
        clr     r23
        ldi     r24, 0x80
        ldi     r25, 0x7F
        bld     r25, 7
        ret
