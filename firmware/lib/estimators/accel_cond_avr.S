; One channel of accel_cond's fixed-point step (accel_cond.h) for the AVR build, inside the
; ESO's assembly front (eso_avr.S): the same operations in the same order as the C twin
; accel_cond_step_q_c (accel_cond.c), so the same bits: the high-pass's 48-bit (Q37) step with
; its 32 × 24 and 32 × 32 products, six products by factors (fx_mul_f_avr's, inline:
; fixmath/fx_step_avr.inc's MULX) and the saturating adds, subtracts and the rescale between
; them. In C the flattened ESO step kept almost nothing
; in registers across the kernel's calls: each add reloaded its operands and each product
; moved its arguments (~1,650 cycles a channel, ~1,000 of them moves).
;
; accel_cond_chan_avr, no frame of its own (the front saves what it uses): ch in Y, c in
; r15:r14, a in r21:r18, status in r17:r16 (where fx_mul_f_avr's entries take it); the
; displacement in r25:r22. Uses r2-r11 (the running value in r5:r2, each product's entry
; in r7:r6, a state kept across a product in r11:r8); counts its saturations in r13, which the front ORs into *status. r1 is left 0.

; accel_chan_q_t (int32 fields) and accel_cond_q_t (5-byte fx_xfactor_t: m, sh, entry) offsets;
; accel_cond.c checks them against the structs
#define CH_X1 0
#define CH_X2 4
#define CH_L1 8
#define CH_L2 12
#define CH_H1 16
#define CH_H2 20
#define CH_DH 24
#define CH_V 28
#define CH_X 32
#define CH_H1_LO 36
#define CH_DH_LO 38
#define C_C2 0                  /* hp_delta_q_t: uint32 c2 (Q24), c12 (Q32) */
#define C_C12 4
#define C_B0 8
#define C_P1 13
#define C_P2 18
#define C_BETA 23
#define C_GAMMA 28

#include "fixmath/fx_step_avr.inc"
#include "fixmath/fx_mul32x24.inc"

; T (r31:r30, r27:r26) <- the int32 at Y+off
.macro LDT off
        ldd     r26, Y+\off
        ldd     r27, Y+\off+1
        ldd     r30, Y+\off+2
        ldd     r31, Y+\off+3
.endm

; P1..P7 += a b3 2^16: a 32 × 24 product's P taken to a 32 × 32 one's by b's fourth byte b3
; (z is 0; r1 is left dirty)
.macro MUL32X8_HI a0, b3, p3, p4, p5, p6, p7, z
        clr     \p7
        mul     \a0, \b3
        add     \p3, r0
        adc     \p4, r1
        adc     \p5, \z
        adc     \p6, \z
        adc     \p7, \z
        mul     \a0+1, \b3
        add     \p4, r0
        adc     \p5, r1
        adc     \p6, \z
        adc     \p7, \z
        mul     \a0+2, \b3
        add     \p5, r0
        adc     \p6, r1
        adc     \p7, \z
        mul     \a0+3, \b3
        add     \p6, r0
        adc     \p7, r1        ; a b < 2^64: no carry out
.endm

; the four bytes from a0 (r16-r31), as unsigned, their magnitude; the sign into T
.macro ABS4 a0
        bst     \a0+3, 7
        brtc    1f
        com     \a0+3
        com     \a0+2
        com     \a0+1
        neg     \a0
        sbci    \a0+1, 0xff
        sbci    \a0+2, 0xff
        sbci    \a0+3, 0xff
1:
.endm

; D (the six bytes from d0) -= P (the six from p0 up, p given one by one) when T is clear,
; += P when T is set: the product's sign; saturated at ±2^47 (the Q37 values' bound), counted
.macro SUB6T d0, p0, p1, p2, p3, p4, p5
        brts    1f
        sub     \d0, \p0
        sbc     \d0+1, \p1
        sbc     \d0+2, \p2
        sbc     \d0+3, \p3
        sbc     \d0+4, \p4
        sbc     \d0+5, \p5
        rjmp    2f
1:      add     \d0, \p0
        adc     \d0+1, \p1
        adc     \d0+2, \p2
        adc     \d0+3, \p3
        adc     \d0+4, \p4
        adc     \d0+5, \p5
2:      SAT6C   \d0
.endm
; BOUND over six bytes from d0 (even): on overflow, the sign fill with its top bit flipped
.macro SAT6C d0
        brvc    1f
        inc     r13
        lsl     \d0+5
        sbc     \d0, \d0
        mov     \d0+1, \d0
        movw    \d0+2, \d0
        movw    \d0+4, \d0
        com     \d0+5
        bst     \d0+5, 7
        mov     \d0+5, \d0
        bld     \d0+5, 7
1:
.endm

        .section .text.accel_cond_chan_avr, "ax", @progbits
        .global accel_cond_chan_avr
accel_cond_chan_avr:
        ; d2 = (a - x1) - (x1 - x2), with x2 <- x1, x1 <- a
        LDY     22, CH_X1       ; B = x1
        LDT     CH_X2           ; T = x2
        STY     CH_X2, 22
        STY     CH_X1, 18
        SUB_AB  SATC                  ; A = a - x1
        sub     r22, r26        ; B = x1 - x2
        sbc     r23, r27
        sbc     r24, r30
        sbc     r25, r31
        SATC    22, 23, 24, 25
        SUB_AB  SATC                  ; A = d2
        ; S (r5:r2) = fx_rescale(d2, 16, ACCEL_QH): d2 2^5, saturated past the top six bits
        mov     r24, r21
        andi    r24, 0xfc
        breq    2f
        cpi     r24, 0xfc
        breq    2f
        inc     r13
        lsl     r21             ; by d2's sign: INT32_MIN, or INT32_MAX
        sbc     r18, r18
        com     r18
        mov     r19, r18
        movw    r20, r18
        subi    r21, 0x80
        MOV4    2, 18
        rjmp    3f
2:      ldi     r22, 32         ; each byte times 32, its high part ORed below the next's
        mul     r18, r22
        movw    r2, r0
        mul     r19, r22
        or      r3, r0
        mov     r4, r1
        mul     r20, r22
        or      r4, r0
        mov     r5, r1
        mul     r21, r22
        or      r5, r0
        clr     r1
3:
        ; dh = ((dh - dh_r c2) + S) - h1 c12 in Q37 (48 bits), dh_r = dh rounded to Q21
        LDY     22, CH_DH
        ldd     r26, Y+CH_DH_LO+1
        lsl     r26             ; the top bit below Q21: + 1/2
        adc     r22, r1
        adc     r23, r1
        adc     r24, r1
        adc     r25, r1
        SATC    22, 23, 24, 25
        ABS4    22              ; a = |dh_r|, its sign in T
        movw    r30, r14
        ldd     r18, Z+C_C2
        ldd     r19, Z+C_C2+1
        ldd     r20, Z+C_C2+2
        MUL32X24 22, 18, r6, r7, r8, r9, r10, r11, r26, rnd ; P (r11:r6) = a c2 2^-8, rounded
        clr     r1
        ldd     r18, Y+CH_DH_LO ; D (r23:r18) = dh in Q37
        ldd     r19, Y+CH_DH_LO+1
        LDY     20, CH_DH
        SUB6T   18, r6, r7, r8, r9, r10, r11
        add     r20, r2         ; + S 2^16
        adc     r21, r3
        adc     r22, r4
        adc     r23, r5
        SAT6C   18
        movw    r6, r18         ; D to r11:r6
        movw    r8, r20
        movw    r10, r22
        LDY     22, CH_H1
        ABS4    22              ; a = |h1|, its sign in T
        movw    r30, r14
        ldd     r18, Z+C_C12
        ldd     r19, Z+C_C12+1
        ldd     r20, Z+C_C12+2
        ldd     r21, Z+C_C12+3
        MUL32X24 22, 18, r2, r3, r4, r5, r26, r27, r30 ; P1..P7 (r2-r5, r26, r27, r31) = a c12 2^-8
        MUL32X8_HI 22, r21, r4, r5, r26, r27, r31, r30
        clr     r1
        lsl     r2              ; rounded to Q37: P1's top bit up
        adc     r3, r30
        adc     r4, r30
        adc     r5, r30
        adc     r26, r30
        adc     r27, r30
        adc     r31, r30
        SUB6T   6, r3, r4, r5, r26, r27, r31
        std     Y+CH_DH_LO, r6
        std     Y+CH_DH_LO+1, r7
        STY     CH_DH, 8
        ; h = h1 + dh in Q37: A (r21:r18) = h's Q21 bits, its 16 below into h1_lo; B = h1
        ldd     r18, Y+CH_H1_LO
        ldd     r19, Y+CH_H1_LO+1
        add     r6, r18
        adc     r7, r19
        LDY     22, CH_H1       ; B = h1 (LDY and MOV4 keep the carry)
        MOV4    18, 22
        adc     r18, r8
        adc     r19, r9
        adc     r20, r10
        adc     r21, r11
        brvc    1f
        inc     r13
        BOUND   18, 19, 20, 21
        mov     r6, r18         ; and the bits below: the bound's fill
        mov     r7, r18
1:      std     Y+CH_H1_LO, r6
        std     Y+CH_H1_LO+1, r7
        ; the low-pass's sum (h >> 2) + (h1 >> 1) + (h2 >> 2), exact in int32;
        ; h2 <- h1, h1 <- h
        LDT     CH_H2           ; T = h2
        STY     CH_H2, 22
        STY     CH_H1, 18
        asr     r25
        ror     r24
        ror     r23
        ror     r22
        .rept   2
        asr     r21
        ror     r20
        ror     r19
        ror     r18
        asr     r31
        ror     r30
        ror     r27
        ror     r26
        .endr
        add     r22, r18
        adc     r23, r19
        adc     r24, r20
        adc     r25, r21
        add     r22, r26
        adc     r23, r27
        adc     r24, r30
        adc     r25, r31
        ; the low-pass: l = ((sum b0 + (l1 - l2)) + (l1 - l1 p1)) + l2 p2
        MULX    14, C_B0, 6
        LDY     18, CH_L1
        MOV4    8, 18           ; l1 kept
        LDT     CH_L2
        sub     r18, r26
        sbc     r19, r27
        sbc     r20, r30
        sbc     r21, r31
        SATC    18, 19, 20, 21
        ADD_AB  SATC
        MOV4    2, 18
        MOV4    22, 8
        MULX    14, C_P1, 6
        MOV4    18, 8
        SUB_AB  SATC
        ADD_AR  SATC, 2
        MOV4    2, 18
        LDY     22, CH_L2
        MULX    14, C_P2, 6
        MOV4    18, 2
        ADD_AB  SATC                  ; A = l
        ; v = (v + (l + l1)) - v γ, with l2 <- l1, l1 <- l
        MOV4    22, 8           ; B = l1
        STY     CH_L2, 22
        STY     CH_L1, 18
        ADD_AB  SATC
        LDY     22, CH_V        ; B = v
        MOV4    8, 22           ; v kept
        ADD_AB  SATC
        MOV4    2, 18
        MULX    14, C_GAMMA, 6         ; B = v γ
        MOV4    18, 2
        SUB_AB  SATC                  ; A = v'
        ; x = (x + (v' + v) β) - x γ, with v <- v'
        MOV4    22, 8           ; B = v
        STY     CH_V, 18
        ADD_AB  SATC
        movw    r22, r18
        movw    r24, r20
        MULX    14, C_BETA, 6
        LDY     18, CH_X
        MOV4    8, 18           ; x kept
        ADD_AB  SATC
        MOV4    2, 18
        MOV4    22, 8
        MULX    14, C_GAMMA, 6
        MOV4    18, 2
        SUB_AB  SATC
        STY     CH_X, 18
        movw    r22, r18
        movw    r24, r20
        ret
