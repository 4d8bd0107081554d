; fx_mul_aN and fx_mul_hN for the AVR build: a · b · 2^-N rounded (aN: ties away from
; zero, as fx_mul; hN: half up, as fx_mul_shr) and saturated to int32, with N fixed when
; the entry is assembled. fixmath.h calls them for a shift known at compile time; the
; native build takes fx_mul_rs_c and fx_mul_shr_c in fixmath.c, which give the same bits
; (tests/hil/test_fixmath_hil.py compares the two on simavr).
;
; The product is the unsigned 32 × 32 of the hardware MUL, column by column, corrected
; for each negative operand; the rounding is one 64-bit add; the shift by N only picks
; registers and shifts a five- or six-byte window by at most four bits, and the bytes
; above the result are compared with its sign to saturate. No int64 library call.
;
; avr-gcc's interface: a in r25:r22, b in r21:r18, status pointer in r17:r16; result in
; r25:r22. Clobbers r0, r18-r27, r30, r31 (call-used); r1 is left 0. No skip over a RET
; (QEMU 7.2 runs one wrong: see firmware/src/mulhisi3.S).

#define SATURATED 0x01          /* STATUS_SATURATED, proto/messages.h */
#include "fx_table_jump.inc"
#include "fx_save_avr.inc"
#define E 26                    /* sign fill of the rounded product: its byte 8 */
#define S 27                    /* sign fill of the result */

; P = a · b, signed 64-bit, in r25:r18 (byte j of P in register 18 + j).
.macro MUL64
        PUSH_RANGE 2, 5, 28, 28
        movw    r2, r18         ; b
        movw    r4, r20
        movw    r26, r22        ; a: r26, r27, r30, r31
        movw    r30, r24
        clr     r28             ; zero
        mul     r26, r2         ; column 0
        movw    r18, r0
        clr     r20
        clr     r21
        MAC     r26, r3, 19     ; column 1
        MAC     r27, r2, 19
        clr     r22             ; column 2
        MAC     r26, r4, 20
        MAC     r27, r3, 20
        MAC     r30, r2, 20
        clr     r23             ; column 3
        MAC     r26, r5, 21
        MAC     r27, r4, 21
        MAC     r30, r3, 21
        MAC     r31, r2, 21
        clr     r24             ; column 4
        MAC     r27, r5, 22
        MAC     r30, r4, 22
        MAC     r31, r3, 22
        clr     r25             ; column 5
        MAC     r30, r5, 23
        MAC     r31, r4, 23
        mul     r31, r5         ; column 6
        add     r24, r0
        adc     r25, r1
        tst     r31             ; a < 0: the unsigned product counted b 2^32 too many
        brpl    1f
        sub     r22, r2
        sbc     r23, r3
        sbc     r24, r4
        sbc     r25, r5
1:      tst     r5              ; b < 0: a 2^32 too many
        brpl    2f
        sub     r22, r26
        sbc     r23, r27
        sbc     r24, r30
        sbc     r25, r31
2:      clr     r1
        POP_RANGE 2, 5, 28, 28
.endm

; registers (lo+1, lo+2, lo+3) += x · y · 2^8·0 aligned at lo (r28 is zero)
.macro MAC x, y, lo
        mul     \x, \y
        add     \lo, r0
        adc     \lo+1, r1
        adc     \lo+2, r28
.endm

.macro SIGN_FILL dst, src      ; dst = 0xff if src < 0 else 0
        mov     \dst, \src
        lsl     \dst
        sbc     \dst, \dst
.endm

; Bytes lo..hi of P (hi <= 7) shifted right arithmetically by n bits.
.macro ASR_BYTES lo, hi, n
        .rept   \n
        asr     18+\hi
        .set    j, \hi-1
        .rept   \hi-\lo
        ror     18+j
        .set    j, j-1
        .endr
        .endr
.endm

; Bytes lo..hi of P (hi <= 8, byte 8 being E) shifted left by n bits.
.macro LSL_BYTES lo, hi, n
        .rept   \n
        lsl     18+\lo
        .set    j, \lo+1
        .rept   \hi-\lo
        .if     j == 8
        rol     E
        .else
        rol     18+j
        .endif
        .set    j, j+1
        .endr
        .endr
.endm

; Saturate unless bytes from..to (to <= 8, byte 8 being E) of P all equal ref: one
; compare, then compares with carry, which keep Z only while every byte matched.
.macro CHECK_BYTES from, to, ref
        .set    h0, (\from)
        .set    h, h0
        .rept   (\to)+1-h0
        .if     h == 8
        .set    cb, E
        .else
        .set    cb, 18+h
        .endif
        .if     h == h0
        cp      cb, \ref
        .else
        cpc     cb, \ref
        .endif
        .set    h, h+1
        .endr
        brne    9f
.endm

; r25:r22 = bytes w..w+3 of P (a byte past 7 is E).
.macro RESULT_FROM w
        .if     \w < 4
        .if     \w % 2 == 0
        movw    24, 20+\w
        movw    22, 18+\w
        .else
        mov     25, 21+\w
        mov     24, 20+\w
        mov     23, 19+\w
        mov     22, 18+\w
        .endif
        .elseif \w > 4
        .set    i, 0
        .rept   4
        .if     \w+i <= 7
        mov     22+i, 18+\w+i
        .else
        mov     22+i, E
        .endif
        .set    i, i+1
        .endr
        .endif
.endm

; One entry: name, shift n (1..62), away (1: ties away from zero, 0: half up).
.macro MUL_ENTRY name, n, away
        .section .text.\name, "ax", @progbits
        .global \name
\name:
        MUL64
        .if     \away           ; P - 1 when P < 0: then adding 2^(n-1) rounds ties down
        SIGN_FILL E, r25
        add     r18, E
        .set    j, 19
        .rept   7
        adc     j, E
        .set    j, j+1
        .endr
        .endif
        .set    k, (\n-1) / 8   ; P + 2^(n-1), from the byte that holds bit n-1
        subi    18+k, (0x100 - (1 << ((\n-1) % 8))) & 0xff
        .set    j, k+1
        .rept   7-k
        sbci    18+j, 0xff
        .set    j, j+1
        .endr
        SIGN_FILL E, r25
        .set    B, \n / 8
        .set    R, \n % 8
        .if     \n >= 32        ; |a · b| <= 2^62: the result cannot leave int32
        ASR_BYTES B, 7, R
        RESULT_FROM B
        .else
        .set    CHECK_TO, 7     ; the result's sign fill in bytes CHECK_FROM..CHECK_TO
        .if     R == 0
        .set    W, B
        .set    CHECK_FROM, B+4
        .elseif R <= 4
        ASR_BYTES B, B+4, R
        .set    W, B
        .set    CHECK_FROM, B+4
        .else                   ; five bits or more: a left shift by 8 - R is shorter
        .if     B+5 <= 7        ; it pushes byte B+5's top bits out, so the bytes from B+5
        CHECK_BYTES B+5, 7, E   ; are P's sign fill before it, and byte B+5 the result's
        .endif                  ; after it (as E, when byte B+5 is E)
        LSL_BYTES B, B+5, 8-R
        .set    W, B+1
        .set    CHECK_FROM, B+5
        .set    CHECK_TO, B+5
        .endif
        SIGN_FILL S, 18+W+3
        CHECK_BYTES CHECK_FROM, CHECK_TO, S
        RESULT_FROM W
        ret
9:      lsl     E               ; saturated: INT32_MAX or INT32_MIN by the product's sign
        sbc     E, E
        mov     r22, E
        com     r22
        mov     r23, r22
        mov     r24, r22
        ldi     r25, 0x7f
        eor     r25, E
        movw    r30, r16
        ld      S, Z
        ori     S, SATURATED
        st      Z, S
        .endif
        ret
.endm

; Every shift, both roundings; --gc-sections keeps the ones called.
#define ENTRIES(n) MUL_ENTRY fx_mul_a##n, n, 1 $ MUL_ENTRY fx_mul_h##n, n, 0
ENTRIES(1) $ ENTRIES(2) $ ENTRIES(3) $ ENTRIES(4) $ ENTRIES(5) $ ENTRIES(6) $ ENTRIES(7) $ ENTRIES(8)
ENTRIES(9) $ ENTRIES(10) $ ENTRIES(11) $ ENTRIES(12) $ ENTRIES(13) $ ENTRIES(14) $ ENTRIES(15) $ ENTRIES(16)
ENTRIES(17) $ ENTRIES(18) $ ENTRIES(19) $ ENTRIES(20) $ ENTRIES(21) $ ENTRIES(22) $ ENTRIES(23) $ ENTRIES(24)
ENTRIES(25) $ ENTRIES(26) $ ENTRIES(27) $ ENTRIES(28) $ ENTRIES(29) $ ENTRIES(30) $ ENTRIES(31) $ ENTRIES(32)
ENTRIES(33) $ ENTRIES(34) $ ENTRIES(35) $ ENTRIES(36) $ ENTRIES(37) $ ENTRIES(38) $ ENTRIES(39) $ ENTRIES(40)
ENTRIES(41) $ ENTRIES(42) $ ENTRIES(43) $ ENTRIES(44) $ ENTRIES(45) $ ENTRIES(46) $ ENTRIES(47) $ ENTRIES(48)
ENTRIES(49) $ ENTRIES(50) $ ENTRIES(51) $ ENTRIES(52) $ ENTRIES(53) $ ENTRIES(54) $ ENTRIES(55) $ ENTRIES(56)
ENTRIES(57) $ ENTRIES(58) $ ENTRIES(59) $ ENTRIES(60) $ ENTRIES(61) $ ENTRIES(62)

; fx_mul64(a, b): the exact int64 product, in r25:r18 where MUL64 leaves it (~60 cycles;
; avr-gcc's widening multiply calls a library routine of ~200).
        .section .text.fx_mul64, "ax", @progbits
        .global fx_mul64
fx_mul64:
        MUL64
        ret

; fx_mul_shr31_q15(a, b, status): a · b · 2^-31 rounded half up, clamped to ±(2^15 - 1) (flagged):
; the product's bytes 3..7 plus 2^30, one bit up, and a test of the top two bytes, where
; fx_mul_h31 then a clamp in C checked two ranges.
        .section .text.fx_mul_shr31_q15, "ax", @progbits
        .global fx_mul_shr31_q15
fx_mul_shr31_q15:
        MUL64
        subi    r21, 0xc0       ; + 2^30
        sbci    r22, 0xff
        sbci    r23, 0xff
        sbci    r24, 0xff
        sbci    r25, 0xff
        bst     r25, 7          ; P's sign (P = 2^62 + 2^30 reads negative below)
        lsl     r21             ; r = P 2^-31 mod 2^32 in r25:r22
        rol     r22
        rol     r23
        rol     r24
        rol     r25
        mov     r0, r23         ; r in -(2^15 - 1) .. 2^15 - 1: r25:r24 r23's sign fill and,
        lsl     r0              ; for a negative r, not -2^15
        sbc     r0, r0
        cp      r24, r0
        cpc     r25, r0
        brne    1f
        tst     r0
        brpl    2f
        cpi     r22, 0
        brne    2f
        cpi     r23, 0x80
        brne    2f
1:      ldi     r22, 0xff       ; +-(2^15 - 1) by P's sign, flagged
        ldi     r23, 0x7f
        brtc    3f
        ldi     r22, 0x01
        ldi     r23, 0x80
3:      movw    r30, r16
        ld      r24, Z
        ori     r24, SATURATED
        st      Z, r24
2:      movw    r24, r22
        ret

; fx_mul64_rs10(a, b): fx_round_shift(a · b, 10) (ties away from zero) as
; floor((P + 2^9 - [P < 0]) 2^-10): one add, a byte dropped and two bit shifts, where the C
; called libgcc's 64-bit shift, compare and negate (~150 cycles more).
        .section .text.fx_mul64_rs10, "ax", @progbits
        .global fx_mul64_rs10
fx_mul64_rs10:
        MUL64
        ldi     r26, 0xff       ; + 2^9 - 1 where P < 0, + 2^9 otherwise
        ldi     r27, 0x01
        tst     r25
        brmi    1f
        clr     r26
        ldi     r27, 0x02
1:      add     r18, r26
        adc     r19, r27
        adc     r20, r1
        adc     r21, r1
        adc     r22, r1
        adc     r23, r1
        adc     r24, r1
        adc     r25, r1
        mov     r18, r19        ; >> 8, then >> 2
        mov     r19, r20
        mov     r20, r21
        mov     r21, r22
        mov     r22, r23
        mov     r23, r24
        mov     r24, r25
        lsl     r25
        sbc     r25, r25
        .rept   2
        asr     r25
        ror     r24
        ror     r23
        ror     r22
        ror     r21
        ror     r20
        ror     r19
        ror     r18
        .endr
        ret

; fx_mul_shr_n(a, b, status, s): fx_mul_hN for a shift known only at run time, by a jump
; through a table of the entries (in .progmem, below 64 KB: LPM with a 16-bit Z; gs()
; lets the linker add a stub where an entry lies past ijmp's 128 KB). a, b and status sit
; where the entry takes them, so it is a jump, not a call: ~15 cycles more than a fixed
; shift. s outside 1..62 gives 0 (the C twin's contract).
        .section .progmem.fx_mul_h_table, "a", @progbits
fx_mul_h_table:
        .irp    n, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 37, 38, 39, 40, 41, 42, 43, 44, 45, 46, 47, 48, 49, 50, 51, 52, 53, 54, 55, 56, 57, 58, 59, 60, 61, 62
        .word   gs(fx_mul_h\n)
        .endr

        .section .text.fx_mul_shr_n, "ax", @progbits
        .global fx_mul_shr_n
fx_mul_shr_n:
        mov     r30, r14        ; s - 1, in 0..61
        dec     r30
        cpi     r30, 62
        brsh    1f
        lsl     r30             ; the entry's word in the table
        clr     r31
        JUMP_THROUGH fx_mul_h_table
1:      clr     r22
        clr     r23
        movw    r24, r22
        ret

; fx_mul_shr_n_sub(a, status, b, acc, n, s): acc[j] -= fx_mul_shr_n(a, b[j], status, s) for
; j < n (modulo 2^32): the entry for s looked up once and called for each product, where a
; call of fx_mul_shr_n each cost its jump through the table and the caller's moves. s
; outside 1..62: acc unchanged (the products are 0).
;
; avr-gcc's interface: a in r25:r22, status in r21:r20, b in r19:r18, acc in r17:r16, n in
; r14, s in r12. Saves r2-r8, r10, r11, r16, r17, r28, r29.
        .section .text.fx_mul_shr_n_sub, "ax", @progbits
        .global fx_mul_shr_n_sub
fx_mul_shr_n_sub:
        PUSH_RANGE 2, 8, 10, 11, 16, 17, 28, 29
        movw    r2, r22         ; a
        movw    r4, r24
        movw    r28, r18        ; Y = b
        movw    r6, r16         ; acc
        movw    r16, r20        ; status, where the entries take it
        mov     r8, r14         ; n
        mov     r30, r12        ; s - 1, in 0..61
        dec     r30
        cpi     r30, 62
        brsh    2f
        lsl     r30             ; the entry's word in the table, into r11:r10
        clr     r31
        subi    r30, lo8(-(fx_mul_h_table))
        sbci    r31, hi8(-(fx_mul_h_table))
        lpm     r10, Z+
        lpm     r11, Z
1:      tst     r8
        breq    2f
        ld      r18, Y+         ; b[j]
        ld      r19, Y+
        ld      r20, Y+
        ld      r21, Y+
        movw    r22, r2
        movw    r24, r4
        movw    r30, r10
        icall
        movw    r30, r6         ; acc[j] -= the product
        ld      r18, Z
        ldd     r19, Z+1
        ldd     r20, Z+2
        ldd     r21, Z+3
        sub     r18, r22
        sbc     r19, r23
        sbc     r20, r24
        sbc     r21, r25
        st      Z+, r18
        st      Z+, r19
        st      Z+, r20
        st      Z+, r21
        movw    r6, r30
        dec     r8
        rjmp    1b
2:      POP_RANGE 2, 8, 10, 11, 16, 17, 28, 29
        ret
