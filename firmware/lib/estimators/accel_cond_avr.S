; One channel of accel_cond's fixed-point step (accel_cond.h) for the AVR build, inside the
; ESO's assembly front (eso_avr.S): the same operations in the same order as the C twin
; accel_cond_step_q_c (accel_cond.c), so the same bits: eight products by factors
; (fx_mul_f_avr's, inline: fixmath/fx_step_avr.inc's MULX) and the saturating adds,
; subtracts and the rescale between them. In C the flattened ESO step kept almost nothing
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
#define C_C2 0
#define C_C12 5
#define C_B0 10
#define C_P1 15
#define C_P2 20
#define C_BETA 25
#define C_GAMMA 30

#include "fixmath/fx_step_avr.inc"

; T (r31:r30, r27:r26) <- the int32 at Y+off
.macro LDT off
        ldd     r26, Y+\off
        ldd     r27, Y+\off+1
        ldd     r30, Y+\off+2
        ldd     r31, Y+\off+3
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
        ; dh = ((dh - dh c2) + S) - h1 c12
        LDY     22, CH_DH
        MOV4    8, 22           ; dh kept
        MULX    14, C_C2, 6
        MOV4    18, 8
        SUB_AB  SATC
        ADD_AR  SATC, 2
        MOV4    2, 18
        LDY     22, CH_H1
        MOV4    8, 22           ; h1 kept
        MULX    14, C_C12, 6
        MOV4    18, 2
        SUB_AB  SATC
        STY     CH_DH, 18
        ; h = h1 + dh; the low-pass's sum (h >> 2) + (h1 >> 1) + (h2 >> 2), exact in int32;
        ; h2 <- h1, h1 <- h
        MOV4    22, 8           ; B = h1
        ADD_AB  SATC                  ; A = h
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
