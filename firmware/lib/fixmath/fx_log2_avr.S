; fx_log2_q24 for the AVR build: log2(x 2^-q) in Q24, as the C twin fx_log2_q24_c in
; fixmath.c (the same bits). The leading bit by whole bytes, then bits on the top three
; bytes only; the table's entries by LPM; (hi - lo) frac 2^-16 rounded half up as six
; 8 × 8 products whose bytes are added into lo and the exponent directly: ~130 cycles, where
; avr-gcc's C took ~255.
;
; avr-gcc's interface: x in r25:r22, q in r20; the result in r25:r22.
; Clobbers r0, r18-r27, r30, r31 (call-used); r1 is left 0.

        .section .text.fx_log2_q24, "ax", @progbits
        .global fx_log2_q24

.Lnone:
        ldi     r25, 0x80       ; INT32_MIN (before the entry: within a branch's reach)
        clr     r24
        clr     r23
        clr     r22
        ret
fx_log2_q24:
        tst     r25
        brmi    .Lnone          ; x < 0
        mov     r0, r22
        or      r0, r23
        or      r0, r24
        or      r0, r25
        breq    .Lnone          ; x = 0
        ldi     r21, 31         ; the leading bit's position, less q: the result's top byte
        sub     r21, r20
1:      tst     r25             ; whole bytes first
        brne    2f
        mov     r25, r24
        mov     r24, r23
        mov     r23, r22
        clr     r22
        subi    r21, 8
        rjmp    1b
2:      sbrc    r25, 7          ; then bits, to bit 31: h = r25:r24 = 2^15 (1 + f); r22's bits
        rjmp    3f              ; never reach h (at most seven shifts)
        lsl     r23
        rol     r24
        rol     r25
        dec     r21
        rjmp    2b
3:      mov     r30, r25        ; Z = the table + 4 idx, idx = h's bits 14..11
        andi    r30, 0x78
        lsr     r30
        clr     r31
        subi    r30, lo8(-(fx_log2_table))
        sbci    r31, hi8(-(fx_log2_table))
        lpm     r18, Z+         ; lo (below 2^24: its top byte is 0)
        lpm     r19, Z+
        lpm     r20, Z+
        adiw    r30, 1
        lpm     r26, Z+         ; hi's low three bytes: hi - lo < 2^21 is exact in them
        lpm     r27, Z+
        lpm     r30, Z
        sub     r26, r18        ; d = hi - lo: r30:r27:r26
        sbc     r27, r19
        sbc     r30, r20
        mov     r23, r25        ; frac = h's bits 10..1 at 15..6: f1 = r23, f0 = r22
        swap    r23
        lsl     r23
        andi    r23, 0xe0
        mov     r22, r24
        lsr     r22
        lsr     r22
        lsr     r22
        or      r23, r22
        mov     r22, r24
        andi    r22, 0x06
        swap    r22
        lsl     r22
        ; P = d frac by bytes P1 (r24), P2 (r25), P3 (r31), P4 (r26); P0 is d0 f0's low byte
        ; alone, so nothing carries out of it
        clr     r25
        clr     r31
        mul     r26, r22        ; d0 f0
        mov     r24, r1
        mul     r26, r23        ; d0 f1 (an 8 × 8 product's high byte is at most 0xfe)
        add     r24, r0
        adc     r25, r1
        clr     r26
        mul     r27, r22        ; d1 f0
        add     r24, r0
        adc     r25, r1
        rol     r31             ; the carry: r31 was 0
        mul     r27, r23        ; d1 f1
        add     r25, r0
        adc     r31, r1
        rol     r26
        clr     r27             ; zero
        mul     r30, r22        ; d2 f0
        add     r25, r0
        adc     r31, r1
        adc     r26, r27
        mul     r30, r23        ; d2 f1
        add     r31, r0
        adc     r26, r1
        clr     r1
        lsl     r24             ; + 2^15: P1's top bit carries
        adc     r18, r25        ; (top - q) 2^24 + lo + (P + 2^15) 2^-16
        adc     r19, r31
        adc     r20, r26
        adc     r21, r27
        movw    r22, r18
        movw    r24, r20
        ret
