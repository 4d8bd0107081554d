; bfp24_from_i64 for the AVR build: exact sums s[0..n) into a block m[0..n) at 2^k, the
; largest keeping 24 bits, each magnitude truncated toward zero; returns k. The C twin
; bfp24_from_i64_c in bfp24.c gives the same bits. Two passes: the magnitudes' union (its
; top bit is the largest's), then each magnitude moved down by k: two bytes a movw, one
; byte, then bits. ~110 cycles a sum.
;
; avr-gcc's interface: s in r25:r24, n in r22, m in r21:r20; k in r24.
; Saves what it uses of r2-r17, r28, r29; r1 is left 0.

#define COUNT r10
#define N r11
#define K r12
#define Q r13

#include "bfp24_neg64.inc"
#include "fixmath/fx_save_avr.inc"

; r25:r18 = |r25:r18|, T = its sign
.macro MAGNITUDE
        bst     r25, 7
        brtc    1f
        NEG64
1:
.endm

.macro LOAD8
        ld      r18, X+
        ld      r19, X+
        ld      r20, X+
        ld      r21, X+
        ld      r22, X+
        ld      r23, X+
        ld      r24, X+
        ld      r25, X+
.endm

        .section .text.bfp24_from_i64, "ax", @progbits
        .global bfp24_from_i64
bfp24_from_i64:
        PUSH_RANGE 2, 15, 28, 29
        movw    r26, r24        ; X = s
        movw    r14, r24        ; (again for the second pass)
        movw    r28, r20        ; Y = m
        mov     N, r22
        clr     r2              ; the magnitudes' union, r9:r2
        clr     r3
        movw    r4, r2
        movw    r6, r2
        movw    r8, r2
        mov     COUNT, N
        tst     COUNT
        breq    3f
2:      LOAD8
        MAGNITUDE
        or      r2, r18
        or      r3, r19
        or      r4, r20
        or      r5, r21
        or      r6, r22
        or      r7, r23
        or      r8, r24
        or      r9, r25
        dec     COUNT
        brne    2b
3:      ldi     r18, 64         ; its bit length: bytes, then the top byte's bits
        ldi     r19, 8
4:      tst     r9
        brne    5f
        mov     r9, r8
        mov     r8, r7
        mov     r7, r6
        mov     r6, r5
        mov     r5, r4
        mov     r4, r3
        mov     r3, r2
        subi    r18, 8
        dec     r19
        brne    4b
        rjmp    6f              ; all zero: 0 bits
5:      sbrc    r9, 7
        rjmp    6f
        lsl     r9
        dec     r18
        rjmp    5b
6:      clr     K               ; k = bits - 24 if positive
        subi    r18, 24
        brlo    7f
        breq    7f
        mov     K, r18
7:      mov     Q, K            ; whole bytes
        lsr     Q
        lsr     Q
        lsr     Q
        movw    r26, r14        ; X = s
        mov     COUNT, N
        tst     COUNT
        brne    8f
        rjmp    14f
8:      LOAD8
        MAGNITUDE
        mov     r30, Q          ; down by whole bytes: two at a time, then one
9:      cpi     r30, 2
        brlo    10f
        movw    r18, r20
        movw    r20, r22
        movw    r22, r24
        subi    r30, 2
        rjmp    9b
10:     tst     r30
        breq    11f
        mov     r18, r19
        mov     r19, r20
        mov     r20, r21
        mov     r21, r22
11:     mov     r30, K          ; then bits (what is left below 2^32)
        andi    r30, 7
        breq    13f
12:     lsr     r21
        ror     r20
        ror     r19
        ror     r18
        dec     r30
        brne    12b
13:     st      Y+, r18         ; the word: magnitude, sign
        st      Y+, r19
        st      Y+, r20
        clr     r21
        bld     r21, 7
        st      Y+, r21
        dec     COUNT
        brne    8b
14:     mov     r24, K
        clr     r1
        POP_RANGE 2, 15, 28, 29
        ret
