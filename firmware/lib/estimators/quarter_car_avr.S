; qcar_strut_over_kus_q for the AVR build: the strut over k_us in metres Q28 from Δx (Q28)
; and Δẋ (Q24), the same operations as the C twin qcar_strut_over_kus_q_c (quarter_car.c),
; so the same bits: Δx to 24 bits (Q23) and Δẋ to 16 (Q12), rounded half up, saturated;
; Horner's rule on them (products round(p |x| 2^-23) and round(p |v| 2^-16), half up, then
; the sign), the saturating adds, then Q20 to Q28. Each product is fixmath's 32 × 24
; MUL32X24 or 32 × 16 MUL32X16 with p's sign corrected in its top bytes (~75 and ~55
; cycles), where avr-gcc's two 16 × 16 products, their sums and its moves cost ~95.
;
; avr-gcc's interface: m (qcar_q_t) in r25:r24, dx in r23:r20, dv in r19:r16, status in
; r15:r14; the strut in r25:r22. Saves r8-r13, r28, r29; r1 is left 0.

#include "fixmath/fx_step_avr.inc"
#include "fixmath/fx_mul32x24.inc"

#define M_S1 22                 /* qcar_q_t's offsets (quarter_car.c checks them) */
#define M_S2 26
#define M_S3 30
#define M_D1 34
#define M_D2 38
#define XSIGN r12               /* Δx's 24-bit and Δẋ's 16-bit values' high bytes, for their signs */
#define VSIGN r13

; b1 (low), b2 (high) <- the int16 Δ 2^-12 rounded half up, for the int32 Δ in b0..b3 (b0 is
; below every bit kept, and a scratch; b1-b3 in r16-r31), saturated past ±2^27 (flagged):
; u = Δ + 2^11 + 2^27 is in range iff u < 2^28, and its bits 12..27, bit 27 flipped back,
; are the result.
.macro DROP12 b0, b1, b2, b3
        mov     \b0, \b3        ; Δ's sign, should it saturate
        subi    \b1, 0xf8       ; u = Δ + 2^11 + 2^27
        sbci    \b2, 0xff
        sbci    \b3, 0xf7
        cpi     \b3, 0x10
        brsh    8f
        swap    \b1
        andi    \b1, 0x0f
        swap    \b2
        mov     \b0, \b2
        andi    \b0, 0xf0
        or      \b1, \b0
        andi    \b2, 0x0f
        swap    \b3
        or      \b2, \b3
        subi    \b2, 0x80
        rjmp    9f
8:      ldi     \b1, 0xff       ; INT16_MAX, or INT16_MIN when Δ < 0
        ldi     \b2, 0x7f
        sbrs    \b0, 7
        rjmp    7f
        ldi     \b1, 0x00
        ldi     \b2, 0x80
7:      FLAG    14, \b0
9:
.endm

; lo, hi (hi in r16-r31) <- their magnitude, as an unsigned 16 bits
.macro ABS16 lo, hi
        tst     \hi
        brpl    1f
        com     \hi
        neg     \lo
        sbci    \hi, 0xff
1:
.endm

; b1..b3 <- the 24-bit Δ 2^-5 rounded half up, for the int32 Δ in b0..b3 (b0 below every
; bit kept, and a scratch; b1-b3 in r16-r31), saturated past ±2^28 (flagged): u = Δ + 2^4 +
; 2^28 is in range iff u < 2^29, and its bits 5..28, bit 28 flipped back, are the result.
.macro DROP5 b0, b1, b2, b3
        mov     r0, \b3        ; Δ's sign, should it saturate
        subi    \b0, 0xf0      ; u = Δ + 2^4 + 2^28
        sbci    \b1, 0xff
        sbci    \b2, 0xff
        sbci    \b3, 0xef
        cpi     \b3, 0x20
        brsh    8f
        .rept   3               ; << 3: bits 5..28 in b1..b3
        lsl     \b0
        rol     \b1
        rol     \b2
        rol     \b3
        .endr
        subi    \b3, 0x80
        rjmp    9f
8:      ldi     \b1, 0xff      ; 2^23 - 1, or -2^23 when Δ < 0
        ldi     \b2, 0xff
        ldi     \b3, 0x7f
        sbrs    r0, 7
        rjmp    7f
        ldi     \b1, 0x00
        ldi     \b2, 0x00
        ldi     \b3, 0x80
7:      FLAG    14, \b0
9:
.endm

; P (r26, r27, r30, r31) <- -P when the sign register's bit 7 is set
.macro NEG_IF sgn
        sbrs    \sgn, 7
        rjmp    1f
        com     r31
        com     r30
        com     r27
        neg     r26
        sbci    r27, 0xff
        sbci    r30, 0xff
        sbci    r31, 0xff
1:
.endm

; P (r26, r27, r30, r31) <- round(p |x| 2^-23), half up, negated when XSIGN's bit 7 is set:
; p in r25:r22 (kept), |x| in r20:r18 (kept). MUL32X24 takes p as unsigned; p < 0 counted
; |x| 2^32 too many, taken off its top bytes. P1..P6 in r21, r26, r27, r30, r31, r17.
.macro TIMES24
        MUL32X24 22, 18, r21, r26, r27, r30, r31, r17, r16
        clr     r1
        sbrs    r25, 7
        rjmp    1f
        sub     r30, r18
        sbc     r31, r19
        sbc     r17, r20
1:      subi    r26, 0xc0       ; + 2^22, then >> 23: bits 23..54 in r27, r30, r31, r17
        sbci    r27, 0xff
        sbci    r30, 0xff
        sbci    r31, 0xff
        sbci    r17, 0xff
        lsl     r26
        rol     r27
        rol     r30
        rol     r31
        rol     r17
        mov     r26, r27
        mov     r27, r30
        mov     r30, r31
        mov     r31, r17
        NEG_IF  XSIGN
.endm

; P (r26, r27, r30, r31) <- round(p |x| 2^-16), half up, negated when the sign register's
; bit 7 is set: p in r25:r22 (kept), |x| in r21:r20 (kept). MUL32X16 takes p as unsigned;
; p < 0 counted |x| 2^32 too many, taken off its top bytes.
.macro TIMES sgn
        MUL32X16 nosh
        clr     r1
        sbrs    r25, 7
        rjmp    1f
        sub     r30, r20
        sbc     r31, r21
1:      subi    r19, 0x80       ; + 2^15
        sbci    r26, 0xff
        sbci    r27, 0xff
        sbci    r30, 0xff
        sbci    r31, 0xff
        NEG_IF  \sgn
.endm

; p (r25:r22) <- the int32 at m + off, plus P, saturated (flagged)
.macro LOAD_ADD off
        LDY     22, \off
        add     r22, r26
        adc     r23, r27
        adc     r24, r30
        adc     r25, r31
        SATS    22, 23, 24, 25, 14
.endm

; P <- (c x + b) x, Horner's step twice (c, b at m + c_off, b_off; x's sign register sgn)
.macro HORNER2 c_off, b_off, sgn
        LDY     22, \c_off
        TIMES   \sgn
        LOAD_ADD \b_off
        TIMES   \sgn
.endm

        .section .text.qcar_strut_over_kus_avr, "ax", @progbits
        .global qcar_strut_over_kus_avr
qcar_strut_over_kus_avr:
        PUSH_RANGE 8, 13, 28, 29
        movw    r28, r24        ; Y = m
        movw    r26, r16        ; v = Δẋ Q24 -> Q12, kept in r11:r10 for the damper
        DROP12  r26, r27, r18, r19
        mov     VSIGN, r18
        ABS16   r27, r18
        mov     r10, r27
        mov     r11, r18
        DROP5   r20, r21, r22, r23      ; x = Δx Q28 -> Q23
        mov     XSIGN, r23
        mov     r18, r21        ; |x| in r20:r18, where TIMES24 takes it
        mov     r19, r22
        mov     r20, r23
        tst     r20
        brpl    1f
        com     r20
        com     r19
        neg     r18
        sbci    r19, 0xff
        sbci    r20, 0xff
1:      ; the spring: ((s3 x + s2) x + s1) x, Q20
        LDY     22, M_S3
        TIMES24
        LOAD_ADD M_S2
        TIMES24
        LOAD_ADD M_S1
        TIMES24
        movw    r20, r10        ; |v|
        movw    r8, r26         ; the spring, kept
        movw    r10, r30
        ; the damper: (d2 v + d1) v, Q24
        HORNER2 M_D2, M_D1, VSIGN
        add     r8, r26         ; spring + damper, Q20
        adc     r9, r27
        adc     r10, r30
        adc     r11, r31
        SATS    8, 9, 10, 11, 14
        ; Q20 -> Q28: << 8, saturated past the top byte (fx_rescale's bound)
        mov     r0, r10
        lsl     r0
        sbc     r0, r0
        cp      r11, r0
        brne    8f
        mov     r25, r10
        mov     r24, r9
        mov     r23, r8
        clr     r22
        rjmp    9f
8:      ldi     r22, 0xff       ; INT32_MAX, or INT32_MIN when negative
        ldi     r23, 0xff
        ldi     r24, 0xff
        ldi     r25, 0x7f
        sbrs    r11, 7
        rjmp    7f
        ldi     r22, 0x00
        ldi     r23, 0x00
        ldi     r24, 0x00
        ldi     r25, 0x80
7:      FLAG    14, r26
9:      POP_RANGE 8, 13, 28, 29
        ret
