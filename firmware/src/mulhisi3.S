; libgcc's signed 16×16 -> 32 multiplies, without skipping a RET.
;
; libgcc ends __mulhisi3 and __usmulhisi3 in a shared tail `sbrs r27, 7; ret; ...`.
; QEMU 7.2's mega2560 mis-executes a skip over RET: it runs that block forever, and
; the board hangs on the first negative second operand. These are the same products
; (the unsigned one, then a correction per negative operand) with branches instead,
; under the same names and the same register interface, so the linker takes them
; instead of libgcc's. In:  r19:r18 (a), r27:r26 (b).  Out: r25:r22.  Clobbers r0.

        .section .text.vehil_mulhisi3, "ax", @progbits

; signed a × signed b
        .global __mulhisi3
__mulhisi3:
        call    __umulhisi3
        tst     r19             ; a < 0: less b 2^16
        brpl    1f
        sub     r24, r26
        sbc     r25, r27
1:      rjmp    negative_b

; unsigned a × signed b
        .global __usmulhisi3
__usmulhisi3:
        call    __umulhisi3
negative_b:
        tst     r27             ; b < 0: less a 2^16
        brpl    2f
        sub     r24, r18
        sbc     r25, r19
2:      ret
