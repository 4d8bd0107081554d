; fx_recip31 for the AVR build: floor(2^31 / l) for 2 <= l < 2^15, as the C twin
; fx_recip31_c in fixmath.c (the same quotient: it is exact). A restoring division with the
; remainder in 16 bits: l's bit length b sets the remainder to 2^(b-2) (below l), the 33 - b
; steps left are the last of 31 written out, entered by a jump past the first b - 2; each
; step's borrow is the quotient bit inverted, shifted into a word of ones and complemented
; at the end: ~11 cycles a bit, where the C's loop took ~15.
;
; avr-gcc's interface: l in r25:r24; the quotient in r25:r22.
; Clobbers r0, r18-r21, r26, r27, r30, r31 (call-used); r1 is left 0.

#define STEP_WORDS 11

; In .lowtext, below 128 KB, where IJMP reaches the steps.
        .section .lowtext.fx_recip31, "ax", @progbits
        .global fx_recip31
fx_recip31:
        movw    r18, r24        ; l
        ldi     r21, 0x40       ; p = 2^(b-1) <= l, b = 15 down
        clr     r20
        ldi     r26, 15
1:      cp      r18, r20
        cpc     r19, r21
        brsh    2f
        lsr     r21
        ror     r20
        dec     r26
        rjmp    1b
2:      lsr     r21             ; the remainder: 2^(b-2)
        ror     r20
        subi    r26, 2          ; the steps skipped
        ldi     r27, STEP_WORDS
        mul     r26, r27
        ldi     r30, pm_lo8(.Lsteps)
        ldi     r31, pm_hi8(.Lsteps)
        add     r30, r0
        adc     r31, r1
        clr     r1
        ldi     r22, 0xff       ; the quotient, its bits inverted
        ldi     r23, 0xff
        ldi     r24, 0xff
        ldi     r25, 0xff
        ijmp
.Lsteps:
        .rept   31
        lsl     r20             ; rem < l < 2^15: doubled, it fits 16 bits
        rol     r21
        cp      r20, r18
        cpc     r21, r19
        brcs    1f              ; rem < l: C = 1, the bit 0 inverted
        sub     r20, r18        ; no borrow: C = 0, the bit 1 inverted
        sbc     r21, r19
1:      rol     r22
        rol     r23
        rol     r24
        rol     r25
        .endr
        com     r22
        com     r23
        com     r24
        com     r25
        ret
