; eso_observer_q for the AVR build: one observer's Euler step (eq. 12; eso.c), the same
; operations as its C twin eso_observer_q_c, so the same bits: five products by factors
; (fx_mul_f_avr's, inline: fixmath/fx_step_avr.inc's MULX) and the saturating adds between
; them. In C the flattened step moved every product's arguments and reloaded every add's
; operands; here z stays in Y, the factors in r11:r10, the error e in r5:r2, each product's
; entry in r7:r6, and the partial sums z0 + z1 T, z1 + acc T wait in z.
;
; avr-gcc's interface: k (the factors T, g1, g2, g3) in r25:r24, z in r23:r22, y in r21:r18,
; status in r17:r16 (where fx_mul_f_avr's entries take it), acc in r15:r12. Saves r2-r7,
; r10, r11, r28, r29; r1 is left 0.

#include "fixmath/fx_step_avr.inc"

#define K_T 0                   /* fx_xfactor_t: 5 bytes (eso.c checks) */
#define K_G1 5
#define K_G2 10
#define K_G3 15

        .section .text.eso_observer_q_avr, "ax", @progbits
        .global eso_observer_q_avr
eso_observer_q_avr:
        push    r2
        push    r3
        push    r4
        push    r5
        push    r6
        push    r7
        push    r10
        push    r11
        push    r28
        push    r29
        movw    r10, r24        ; k
        movw    r28, r22        ; Y = z
        LDY     22, 0           ; e = y - z0
        SUB_AB  SATS
        MOV4    2, 18
        LDY     22, 4           ; z0 <- z0 + z1 T
        MULX    10, K_T, 6
        LDY     18, 0
        ADD_AB  SATS
        STY     0, 18
        MOV4    22, 12          ; z1 <- z1 + acc T
        MULX    10, K_T, 6
        LDY     18, 4
        ADD_AB  SATS
        STY     4, 18
        MOV4    22, 2           ; z0 <- z0 + e g1
        MULX    10, K_G1, 6
        LDY     18, 0
        ADD_AB  SATS
        STY     0, 18
        MOV4    22, 2           ; z1 <- z1 + e g2
        MULX    10, K_G2, 6
        LDY     18, 4
        ADD_AB  SATS
        STY     4, 18
        MOV4    22, 2           ; z2 <- z2 + e g3
        MULX    10, K_G3, 6
        LDY     18, 8
        ADD_AB  SATS
        STY     8, 18
        pop     r29
        pop     r28
        pop     r11
        pop     r10
        pop     r7
        pop     r6
        pop     r5
        pop     r4
        pop     r3
        pop     r2
        ret
