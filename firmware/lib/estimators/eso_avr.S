; eso_observer_q for the AVR build: one observer's Euler step (eq. 12; eso.c), the same
; operations in the same order as its C twin observer_q_c, so the same bits: five products
; by factors (fixmath's fx_mul_f_avr) and the saturating adds between them. In C the
; flattened step moved every product's arguments and reloaded every add's operands; here z
; stays in Y, the factors in r11:r10, the error e in r5:r2 and the running sum in r9:r6.
;
; avr-gcc's interface: k (the factors T, g1, g2, g3) in r25:r24, z in r23:r22, y in r21:r18,
; status in r17:r16 (where fx_mul_f_avr takes it), acc in r15:r12. Saves r2-r11, r28, r29;
; r1 is left 0.

#include "fixmath/fx_step_avr.inc"

#define K_T 0                   /* fx_factor_t: 3 bytes (eso.c checks) */
#define K_G1 3
#define K_G2 6
#define K_G3 9

        .section .text.eso_observer_q_avr, "ax", @progbits
        .global eso_observer_q_avr
eso_observer_q_avr:
        push    r2
        push    r3
        push    r4
        push    r5
        push    r6
        push    r7
        push    r8
        push    r9
        push    r10
        push    r11
        push    r28
        push    r29
        movw    r10, r24        ; k
        movw    r28, r22        ; Y = z
        LDY     22, 0           ; e = y - z0
        SUB_AB  SATS
        MOV4    2, 18
        LDY     22, 4           ; z0 <- (z0 + z1 T) + e g1
        MULF    10, K_T
        LDY     18, 0
        ADD_AB  SATS
        MOV4    6, 18
        MOV4    22, 2
        MULF    10, K_G1
        MOV4    18, 6
        ADD_AB  SATS
        STY     0, 18
        MOV4    22, 12          ; z1 <- (z1 + acc T) + e g2
        MULF    10, K_T
        LDY     18, 4
        ADD_AB  SATS
        MOV4    6, 18
        MOV4    22, 2
        MULF    10, K_G2
        MOV4    18, 6
        ADD_AB  SATS
        STY     4, 18
        MOV4    22, 2           ; z2 <- z2 + e g3
        MULF    10, K_G3
        LDY     18, 8
        ADD_AB  SATS
        STY     8, 18
        pop     r29
        pop     r28
        pop     r11
        pop     r10
        pop     r9
        pop     r8
        pop     r7
        pop     r6
        pop     r5
        pop     r4
        pop     r3
        pop     r2
        ret
