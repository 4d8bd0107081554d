; fx_mul_f for the AVR build: a · (±m 2^-sh) for an int32 a and a constant factor kept as a
; 16-bit mantissa m and a shift 9 <= sh <= 47 (the factor's sign in sh's bit 7: fixmath.h's
; fx_factor_t), rounded to nearest with ties away from zero and saturated to int32 (flagged).
; |a| times m by the eight hardware products of its four bytes by m's two; then a jump
; through a flash table (as fx_mul_shr_n) to an entry written for that shift, whose rounding
; add and shift are unrolled: a byte choice and at most seven bit shifts, no loop; then the
; sign. The C twin fx_mul_f_c in fixmath.c gives the same bits.
;
; avr-gcc's interface: a in r25:r22, m in r21:r20, sh in r18, status pointer in r17:r16;
; result in r25:r22. Clobbers r0, r18-r27, r30, r31 (call-used); r1 is left 0. No skip over
; a RET (QEMU 7.2 runs one wrong: see firmware/src/mulhisi3.S).

#define SATURATED 0x01          /* STATUS_SATURATED, proto/messages.h */
#include "fx_mul32x16.inc"
#include "fx_table_jump.inc"

; Q = P >> 8 (P = |a| m < 2^47) lives in five registers, byte i of Q in QREG(i):
; r19, r26, r27, r20, r21. r18 is zero (and takes the bits shifted past r21 when an entry
; shifts left: R >= 5); so is r1.
.macro QR out, i
        .if     \i == 0
        .set    \out, 19
        .elseif \i == 1
        .set    \out, 26
        .elseif \i == 2
        .set    \out, 27
        .elseif \i == 3
        .set    \out, 20
        .else
        .set    \out, 21
        .endif
.endm

; The entry for shift n: floor((P + 2^(n-1)) 2^-n) = floor((Q + 2^(s-1)) 2^-s), s = n - 8.
; In .lowtext, which the linker puts below 128 KB: ICALL and IJMP reach it directly, where
; gs() of an entry past 128 KB goes through a stub's JMP (3 cycles a product).
.macro MULF_ENTRY n
        .section .lowtext.fx_mul_f\n, "ax", @progbits
        .global fx_mul_f\n     ; named, so that profiles name it
fx_mul_f\n:
        .set    s, \n - 8
        .set    b, s - 1        ; + 2^b, from the byte that holds bit b up
        .set    j, b / 8
        QR      rr, j
        subi    rr, (0x100 - (1 << (b % 8))) & 0xff
        .rept   4 - b / 8
        .set    j, j + 1
        QR      rr, j
        sbci    rr, 0xff
        .endr
        .set    B, s / 8        ; >> s: bytes from B, then R bits
        .set    R, s % 8
        .if     R < 5
        .rept   R
        lsr     21
        .set    j, 3
        .rept   4 - B
        QR      rr, j
        ror     rr
        .set    j, j - 1
        .endr
        .endr
        .set    hi, 21          ; the byte above the result (when B = 0)
        .else                   ; or << 8 - R into r18, then bytes from B + 1: fewer shifts
        .rept   8 - R
        .set    j, B
        QR      rr, j
        lsl     rr
        .rept   4 - B
        .set    j, j + 1
        QR      rr, j
        rol     rr
        .endr
        rol     18
        .endr
        .set    B, B + 1
        .set    hi, 18
        .endif
        .set    i, 0
        .rept   4
        .if     B + i <= 4
        QR      rr, B + i
        mov     22 + i, rr
        .elseif B + i == 5
        mov     22 + i, 18
        .else
        mov     22 + i, 1       ; r1 is 0
        .endif
        .set    i, i + 1
        .endr
        .if     s < 8           ; |a| m 2^-n can pass 2^31 - 1 only for n < 16
        tst     hi
        brne    8f
        sbrc    25, 7
        rjmp    8f
        .endif
7:      brtc    9f
        com     25              ; negative: the magnitude negated
        com     24
        com     23
        neg     22
        sbci    23, 0xff
        sbci    24, 0xff
        sbci    25, 0xff
9:      ret
        .if     s < 8
8:      brtc    10f             ; past it: exactly 2^31 is INT32_MIN when negative
        tst     hi
        brne    10f
        cpi     25, 0x80
        brne    10f
        mov     0, 24
        or      0, 23
        or      0, 22
        brne    10f
        rjmp    7b
10:     ldi     22, 0xff        ; saturated: INT32_MAX, or INT32_MIN when negative
        ldi     23, 0xff
        ldi     24, 0xff
        ldi     25, 0x7f
        brtc    11f
        ldi     22, 0
        ldi     23, 0
        ldi     24, 0
        ldi     25, 0x80
11:     movw    30, 16
        ld      18, Z
        ori     18, SATURATED
        st      Z, 18
        ret
        .endif
.endm

        .irp    n, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 37, 38, 39, 40, 41, 42, 43, 44, 45, 46, 47
        MULF_ENTRY \n
        .endr

; the entries by shift, for JUMP_THROUGH
        .section .progmem.fx_mul_f_table, "a", @progbits
fx_mul_f_table:
        .irp    n, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 37, 38, 39, 40, 41, 42, 43, 44, 45, 46, 47
        .word   gs(fx_mul_f\n)
        .endr

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
1:
        MUL32X16
        clr     r1
        movw    r20, r30        ; P4, P5 out of Z
        mov     r30, r22        ; the entry for sh (9..47)
        subi    r30, 9
        lsl     r30
        clr     r31
        JUMP_THROUGH fx_mul_f_table

; fx_mul_f_entry(sh): the word address JUMP_THROUGH takes for a factor's shift (sh in r24, its
; sign bit ignored), in r25:r24: fixmath.h's fx_xfactor keeps it beside the factor, so that
; the assembly steps (fx_step_avr.inc's MULX) call the entry without the table.
        .section .text.fx_mul_f_entry, "ax", @progbits
        .global fx_mul_f_entry
fx_mul_f_entry:
        mov     r30, r24
        andi    r30, 0x3f
        subi    r30, 9
        lsl     r30
        clr     r31
        subi    r30, lo8(-(fx_mul_f_table))
        sbci    r31, hi8(-(fx_mul_f_table))
        lpm     r24, Z+
        lpm     r25, Z
        ret
