; The ESO's fixed-point front for the AVR build (eso.c's eso_front_q): both conditioning
; channels (accel_cond_avr.S) and both observers' Euler steps (eq. 12), the same operations
; in the same order as the C twin (eso_front_q_c: accel_cond_step_q_c, observer_q), so the
; same bits. One frame for the four, where four calls from C each saved its registers and set up
; its arguments; the channels' and the observers' saturations are counted in r13 and ORed
; into *status once.
;
; Given out, the variant-A rest of the step (eso.c's back_q) follows in the same frame:
; Δx̂ and Δẋ̂, the strut over k_us (quarter_car_avr.S) or, road_from, the body's -m_s F̂1, the
; road x̂_r, the outputs from z, the controller (susp_ctrl_step_q, reading the outputs as
; the estimate) and u.
;
; avr-gcc's interface: s (eso_q_t) in r25:r24, in (the SAMPLE's a_s, a_us) in r23:r22,
; status in r21:r20 (moved to r17:r16, where fx_mul_f_avr's entries take it), out in
; r19:r18 (NULL: the front alone), road_from in r16. Saves r2-r17, r28, r29; r1 is left 0.

#include "fixmath/fx_step_avr.inc"

#define S_MODEL 33              /* eso_q_t's offsets (eso.c checks them) */
#define M_R_M_US 16             /* qcar_q_t's m_us/k_us and m_s/k_us (fx_factor_t) */
#define M_R_M_S 19
#define S_CTRL 75
#define CTRL_ACTIVE 25
#define S_U 181
#define S_CH0 101
#define CH_SIZE 40
#define S_K 185
#define S_Z 205
#define Z_ACC 24                /* acc[2] right after z[6] */
#define Z_FNL 32
#define Z_MODEL_IN 36           /* model_in after acc and fnl */
#define K_T 0                   /* fx_xfactor_t: 5 bytes */
#define K_G1 5
#define K_G2 10
#define K_G3 15

; z at Y + off <- itself + B times the factor at k + koff, saturated
.macro MAC off, koff
        MULX    14, \koff, 6
        LDY     18, \off
        ADD_AB  SATC
        STY     \off, 18
.endm

; r21:r20, r18 <- the model's factor at off (m, sh), Y at s->z
.macro FACTOR off
        movw    r30, r28
        subi    r30, lo8(S_Z - S_MODEL - \off)
        sbci    r31, hi8(S_Z - S_MODEL - \off)
        ld      r20, Z+
        ld      r21, Z+
        ld      r18, Z
.endm

; n bytes from Y + off to X+
.macro COPY off, n
        .set    j, \off
        .rept   \n
        ldd     r0, Y+j
        st      X+, r0
        .set    j, j + 1
        .endr
.endm

; acc (r11:r8) <- the observer's acceleration input, its z at Y: s->acc's at Y + off when
; the model's term enters (model_in at Y + flag), else z's third state
.macro ACC off, flag
        ldd     r8, Y+\flag
        tst     r8
        breq    1f
        LDY     8, \off
        rjmp    2f
1:      LDY     8, 8
2:
.endm

; One observer, no frame: z in Y, the factors in r15:r14, y in r5:r2, acc in r11:r8. Uses
; r2-r11 (e in r5:r2, each product's entry in r7:r6, z1 and then z0 + z1 T in r11:r8) and
; counts its saturations in r13. The order of eq. 12's independent terms differs from the
; C twin's (z1 + acc T first, which frees acc's registers), their bits do not: each term is
; the same fx_add of the same operands.
        .section .text.eso_observer_avr, "ax", @progbits
eso_observer_avr:
        MOV4    22, 8
        MULX    14, K_T, 6      ; B = acc T
        LDY     18, 4
        MOV4    8, 18           ; z1 kept
        ADD_AB  SATC
        STY     4, 18           ; z1 <- z1 + acc T
        MOV4    22, 8
        MULX    14, K_T, 6      ; B = z1 T
        LDY     18, 0           ; A = z0
        sub     r2, r18         ; e = y - z0
        sbc     r3, r19
        sbc     r4, r20
        sbc     r5, r21
        SATC    2, 3, 4, 5
        ADD_AB  SATC
        MOV4    8, 18           ; z0 + z1 T kept
        MOV4    22, 2
        MULX    14, K_G1, 6
        MOV4    18, 8
        ADD_AB  SATC
        STY     0, 18           ; z0 <- z0 + z1 T + e g1
        MOV4    22, 2
        MAC     4, K_G2         ; z1 <- z1 + e g2
        MOV4    22, 2
        MAC     8, K_G3         ; z2 <- z2 + e g3
        ret

        .section .text.eso_front_q_avr, "ax", @progbits
        .global eso_front_q_avr
eso_front_q_avr:
        PUSH_RANGE 2, 17, 28, 29
        mov     r12, r16        ; road_from, for the back
        push    r19             ; out waits on the stack
        push    r18
        movw    r16, r20        ; status, where fx_mul_f_avr's entries take it
        clr     r13
        movw    r14, r24        ; the conditioning's coefficients: s's first field
        movw    r28, r24        ; Y = s->ecu.ch[0]
        subi    r28, lo8(-(S_CH0))
        sbci    r29, hi8(-(S_CH0))
        movw    r30, r22        ; a_s
        push    r31             ; in waits on the stack: the channels use r8-r11
        push    r30
        ld      r18, Z+
        ld      r19, Z+
        ld      r20, Z+
        ld      r21, Z+
        call    accel_cond_chan_avr
        pop     r30             ; a_us
        pop     r31
        push    r25             ; y_s waits on the stack
        push    r24
        push    r23
        push    r22
        adiw    r28, CH_SIZE    ; Y = s->ecu.ch[1]
        ldd     r18, Z+4
        ldd     r19, Z+5
        ldd     r20, Z+6
        ldd     r21, Z+7
        call    accel_cond_chan_avr
        MOV4    2, 22           ; y_us
        movw    r14, r28        ; the factors: s->k, from Y = s->ecu.ch[1]
        ldi     r30, lo8(S_K - S_CH0 - CH_SIZE)
        ldi     r31, hi8(S_K - S_CH0 - CH_SIZE)
        add     r14, r30
        adc     r15, r31
        subi    r28, lo8(-(S_Z + 12 - S_CH0 - CH_SIZE)) ; Y = s->z + 3: the unsprung observer first
        sbci    r29, hi8(-(S_Z + 12 - S_CH0 - CH_SIZE))
        ACC     Z_ACC - 12 + 4, Z_MODEL_IN - 12
        call    eso_observer_avr
        pop     r2              ; y_s
        pop     r3
        pop     r4
        pop     r5
        sbiw    r28, 12         ; Y = s->z
        ACC     Z_ACC, Z_MODEL_IN
        call    eso_observer_avr
        pop     r10             ; out
        pop     r11
        mov     r0, r10
        or      r0, r11
        brne    7f
        rjmp    6f              ; (breq does not reach past the back)
7:        ; the back: Δx̂ = z0 - z3 (r23:r20) and Δẋ̂ = z1 - z4 (r19:r16), as the strut takes them
        movw    r14, r16        ; status, where the strut takes it
        LDY     20, 0
        LDY     24, 12
        sub     r20, r24
        sbc     r21, r25
        sbc     r22, r26
        sbc     r23, r27
        SATC    20, 21, 22, 23
        LDY     16, 4
        LDY     24, 16
        sub     r16, r24
        sbc     r17, r25
        sbc     r18, r26
        sbc     r19, r27
        SATC    16, 17, 18, 19
        tst     r12
        brne    1f
        movw    r24, r28        ; m = s->ecu.model
        subi    r24, lo8(S_Z - S_MODEL)
        sbci    r25, hi8(S_Z - S_MODEL)
        call    qcar_strut_over_kus_avr
        MOV4    6, 22           ; the strut over k_us, kept
1:      movw    r16, r14        ; status, where fx_mul_f_avr takes it
        LDY     22, 20          ; x̂_r = x̂_us + F̂2 m_us/k_us (F̂2 = z5)
        FACTOR  M_R_M_US
        call    fx_mul_f_avr
        LDY     18, 12
        ADD_AB  SATC
        tst     r12
        breq    2f
        MOV4    6, 18           ; road_from: + F̂1 m_s/k_us (F̂1 = z2)
        LDY     22, 8
        FACTOR  M_R_M_S
        call    fx_mul_f_avr
        MOV4    18, 6
        ADD_AB  SATC
        rjmp    3f
2:      MOV4    22, 6           ; else - the strut over k_us
        SUB_AB  SATC
3:      movw    r26, r10        ; the outputs: x̂_s, v̂_s, x̂_us, v̂_us, F̂1, F̂2 from z, x̂_r
        COPY    0, 8
        COPY    12, 8
        COPY    8, 4
        COPY    20, 4
        st      X+, r18
        st      X+, r19
        st      X+, r20
        st      X+, r21
        std     Y+Z_FNL, r1     ; fnl = 0 (variant A)
        std     Y+Z_FNL+1, r1
        std     Y+Z_FNL+2, r1
        std     Y+Z_FNL+3, r1
        movw    r30, r28        ; u: the controller's, reading the outputs as its estimate
        subi    r30, lo8(S_Z - S_CTRL - CTRL_ACTIVE)
        sbci    r31, hi8(S_Z - S_CTRL - CTRL_ACTIVE)
        ld      r24, Z
        tst     r24
        breq    4f
        movw    r24, r28
        subi    r24, lo8(S_Z - S_CTRL)
        sbci    r25, hi8(S_Z - S_CTRL)
        movw    r22, r10
        movw    r20, r14
        call    susp_ctrl_step_q
        rjmp    5f
4:      clr     r22             ; off: 0
        clr     r23
        movw    r24, r22
5:      movw    r30, r28        ; s->ecu.u and the outputs' last
        sbiw    r30, S_Z - S_U
        st      Z+, r22
        st      Z+, r23
        st      Z+, r24
        st      Z+, r25
        movw    r26, r10
        adiw    r26, 28
        st      X+, r22
        st      X+, r23
        st      X+, r24
        st      X+, r25
6:      tst     r13             ; the saturations, into *status
        breq    1f
        FLAG    16, r18
1:      POP_RANGE 2, 17, 28, 29
        ret
