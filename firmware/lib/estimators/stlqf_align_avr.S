; stlqf_align_q for the AVR build: the window's rows in int32 at one exponent per input, as
; the C twin stlqf_align_q_c in stlqf.c (the same bits). The peaks by signed compares, then
; each row's three shifts once, each mantissa loaded, shifted by whole bytes and then bits,
; rounded and stored where avr-gcc reloaded the row and the shifts for each of the five.
;
; avr-gcc's interface: rows in r25:r24 (stlqf_row_q_t: m[5] then k[3], 23 bytes; stlqf.c
; checks the layout), head in r22, peak in r21:r20, out (int32_t[5][9]) in r19:r18.
; Clobbers r0, r18-r27, r30, r31 (call-used) and saves r12-r17; r1 is left 0.

#include "fixmath/fx_save_avr.inc"

#define ROW 23                  /* sizeof(stlqf_row_q_t) */
#define K 20                    /* its k[3] */
#define ROWS 9

        .section .text.stlqf_align_q, "ax", @progbits
        .global stlqf_align_q

; peak (p) = the larger of itself and the k at Z + off, signed
.macro  PEAK p, off
        ldd     r18, Z+\off
        cp      \p, r18
        brge    1f
        mov     \p, r18
1:
.endm

; the next mantissa (at Z, advanced) times 2^-d rounded half up to out (at X, then the same
; row of the next mantissa): v unchanged for d = 0, 0 for d > 30, otherwise
; ((v >> (d - 1)) + 1) >> 1, the shift by whole bytes and then bits
.macro  ENTRY d
        ld      r22, Z+
        ld      r23, Z+
        ld      r24, Z+
        ld      r25, Z+
        mov     r18, \d
        subi    r18, 1          ; d - 1 (a borrow: d = 0)
        brcs    3f
        cpi     r18, 30
        brsh    4f
        sbrs    r18, 4
        rjmp    1f
        movw    r22, r24        ; >> 16
        mov     r24, r25
        lsl     r24
        sbc     r24, r24
        mov     r25, r24
1:      sbrs    r18, 3
        rjmp    2f
        mov     r22, r23        ; >> 8
        mov     r23, r24
        mov     r24, r25
        lsl     r25
        sbc     r25, r25
2:      andi    r18, 7
        breq    5f
6:      asr     r25
        ror     r24
        ror     r23
        ror     r22
        dec     r18
        brne    6b
5:      subi    r22, 0xff       ; + 1, then >> 1
        sbci    r23, 0xff
        sbci    r24, 0xff
        sbci    r25, 0xff
        asr     r25
        ror     r24
        ror     r23
        ror     r22
        rjmp    3f
4:      clr     r22
        clr     r23
        movw    r24, r22
3:      st      X+, r22
        st      X+, r23
        st      X+, r24
        st      X+, r25
        adiw    r26, 4 * ROWS - 4
.endm

stlqf_align_q:
        PUSH_RANGE 12, 17
        movw    r26, r18        ; X = out
        movw    r12, r24        ; rows
        movw    r14, r20        ; peak
        movw    r30, r24        ; the peaks over the nine rows: r19, r20, r21
        ldi     r19, 0x80
        mov     r20, r19
        mov     r21, r19
        ldi     r17, ROWS
7:      PEAK    r19, K
        PEAK    r20, K + 1
        PEAK    r21, K + 2
        adiw    r30, ROW
        dec     r17
        brne    7b
        movw    r30, r14
        st      Z+, r19
        st      Z+, r20
        st      Z, r21
        movw    r14, r24        ; the ring's end: rows + 9 rows
        ldi     r18, lo8(ROW * ROWS)
        add     r14, r18
        adc     r15, r1
        ldi     r18, ROW        ; Z = rows[head]
        mul     r22, r18
        movw    r30, r0
        add     r30, r24
        adc     r31, r25
        ldi     r17, ROWS
8:      ldd     r18, Z+K        ; the row's shifts: d0 (r0), d1 (r1), d2 (r16)
        mov     r0, r19
        sub     r0, r18
        ldd     r18, Z+K+1
        mov     r1, r20
        sub     r1, r18
        ldd     r18, Z+K+2
        mov     r16, r21
        sub     r16, r18
        ENTRY   r0              ; v̇'s ψ̃, ½ρv²'s, their time columns' e, ζ
        ENTRY   r1
        ENTRY   r0
        ENTRY   r1
        ENTRY   r16
        adiw    r30, 3          ; past k: the next row, or the ring's first
        cp      r30, r14
        cpc     r31, r15
        brne    9f
        movw    r30, r12
9:      subi    r26, lo8(5 * 4 * ROWS - 4) ; X: out's next row j
        sbci    r27, hi8(5 * 4 * ROWS - 4)
        dec     r17
        breq    10f
        rjmp    8b              ; the loop's body is past a branch's reach
10:     clr     r1
        POP_RANGE 12, 17
        ret
