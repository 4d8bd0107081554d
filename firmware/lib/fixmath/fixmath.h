/* Saturating, rounding int32 fixed point (Q formats), for the FIXED numeric mode.
 *
 * A value x with q fractional bits is stored as round(x * 2^q) in an int32.
 * Every operation names the Q formats it works in, rounds to nearest (ties
 * away from zero) and saturates to the int32 range; saturation ORs
 * STATUS_SATURATED into *status, so nothing wraps silently. Only stdint types
 * and C99, so the AVR build and the host build give identical bits. */
#ifndef VEHIL_FIXMATH_FIXMATH_H
#define VEHIL_FIXMATH_FIXMATH_H

#include <stdint.h>

#include "proto/messages.h"

#ifdef __cplusplus
extern "C" { /* C linkage for C++ wrappers of vendored libraries */
#endif

#define FX_MAX INT32_MAX
#define FX_MIN INT32_MIN

/* The kernels below are always inlined, so that a Q format or shift given as a constant
 * is folded where it is used (GCC would otherwise keep one out-of-line copy). */
#define FX_INLINE static inline __attribute__((always_inline))

/* At file scope beside an assembly kernel's C twin: the build fails where the C layout no
 * longer matches the byte offsets the assembly reads (`ok`: offsetof and sizeof checks). */
#define FX_ASM_LAYOUT(name, ok) typedef char fx_asm_layout_##name[(ok) ? 1 : -1]
#define FX_ASM_OFFSET(type, field, at) FX_ASM_LAYOUT(type##_##field, offsetof(type, field) == (at))

/* x >> n and x << n for a run-time n < 32, whole bytes first (the AVR shifts an int32 one
 * bit at a time, in a loop). */
FX_INLINE uint32_t fx_shr32(uint32_t x, uint8_t n)
{
    if (n & 16u) {
        x >>= 16;
    }
    if (n & 8u) {
        x >>= 8;
    }
    return x >> (n & 7u);
}

FX_INLINE uint32_t fx_shl32(uint32_t x, uint8_t n)
{
    if (n & 16u) {
        x <<= 16;
    }
    if (n & 8u) {
        x <<= 8;
    }
    return x << (n & 7u);
}

/* x clamped to int32, flagging saturation. */
int32_t fx_sat(int64_t x, uint8_t *status);

/* Saturating add, subtract and negate, inline. On the AVR a few instructions read the
 * overflow flag (avr-gcc 5.4 turns __builtin_add_overflow into ~60 cycles of compares);
 * the host's C below gives the same result. On overflow the wrapped result has the
 * wrong sign, so its sign fill with the top bit flipped is the bound: INT32_MAX for a
 * wrapped negative, INT32_MIN for a wrapped positive. Only instructions that take any
 * register (the flip through T: bst, bld), so GCC need not move the operands into r16-r31. */
#if defined(__AVR__)
#define FX_AVR_SATURATE                                                                        \
    "brvc 1f\n\t"                                                                              \
    "inc %1\n\t"                                                                               \
    "lsl %D0\n\t"                                                                              \
    "sbc %A0, %A0\n\t"                                                                         \
    "mov %B0, %A0\n\t"                                                                         \
    "movw %C0, %A0\n\t"                                                                        \
    "com %D0\n\t"                                                                              \
    "bst %D0, 7\n\t"                                                                           \
    "mov %D0, %A0\n\t"                                                                         \
    "bld %D0, 7\n"                                                                              \
    "1:"

FX_INLINE int32_t fx_add(int32_t a, int32_t b, uint8_t *status)
{
    uint8_t sat = 0;
    __asm__("add %A0, %A2\n\tadc %B0, %B2\n\tadc %C0, %C2\n\tadc %D0, %D2\n\t" FX_AVR_SATURATE
            : "+r"(a), "+r"(sat)
            : "r"(b));
    if (sat) {
        *status |= STATUS_SATURATED;
    }
    return a;
}

FX_INLINE int32_t fx_sub(int32_t a, int32_t b, uint8_t *status)
{
    uint8_t sat = 0;
    __asm__("sub %A0, %A2\n\tsbc %B0, %B2\n\tsbc %C0, %C2\n\tsbc %D0, %D2\n\t" FX_AVR_SATURATE
            : "+r"(a), "+r"(sat)
            : "r"(b));
    if (sat) {
        *status |= STATUS_SATURATED;
    }
    return a;
}
#undef FX_AVR_SATURATE
#else
FX_INLINE int32_t fx_add(int32_t a, int32_t b, uint8_t *status)
{
    int32_t r;
    if (__builtin_add_overflow(a, b, &r)) {
        *status |= STATUS_SATURATED;
        return a < 0 ? FX_MIN : FX_MAX;
    }
    return r;
}

FX_INLINE int32_t fx_sub(int32_t a, int32_t b, uint8_t *status)
{
    int32_t r;
    if (__builtin_sub_overflow(a, b, &r)) {
        *status |= STATUS_SATURATED;
        return a < 0 ? FX_MIN : FX_MAX;
    }
    return r;
}
#endif

FX_INLINE int32_t fx_neg(int32_t a, uint8_t *status) { return fx_sub(0, a, status); }

/* x * 2^-shift rounded to nearest, ties away from zero; shift may be negative. */
int64_t fx_round_shift(int64_t x, int8_t shift);

/* The multiply kernels: a · b · 2^-s for 1 <= s <= 62, saturated to int32 (flagged).
 * fx_mul_rs rounds to nearest with ties away from zero (fx_mul's rounding), fx_mul_shr
 * half up. On the AVR a shift known at compile time calls an assembly entry written for
 * that shift (fx_mul_avr.S: ~150 cycles, no int64 library call); the host, and a shift
 * only known at run time, take the C twins below, which give the same bits. */
int32_t fx_mul_rs_c(int32_t a, int32_t b, uint8_t s, uint8_t *status);
int32_t fx_mul_shr_c(int32_t a, int32_t b, uint8_t s, uint8_t *status);

/* Every shift the kernels take, for a switch that reaches each at compile time. */
#define FX_SHIFTS(X)                                                                          \
    X(1) X(2) X(3) X(4) X(5) X(6) X(7) X(8) X(9) X(10) X(11) X(12) X(13) X(14) X(15) X(16) \
    X(17) X(18) X(19) X(20) X(21) X(22) X(23) X(24) X(25) X(26) X(27) X(28) X(29) X(30) \
    X(31) X(32) X(33) X(34) X(35) X(36) X(37) X(38) X(39) X(40) X(41) X(42) X(43) X(44) \
    X(45) X(46) X(47) X(48) X(49) X(50) X(51) X(52) X(53) X(54) X(55) X(56) X(57) X(58) \
    X(59) X(60) X(61) X(62)
#if defined(__AVR__)
#define FX_DECLARE(n)                                                                          \
    int32_t fx_mul_a##n(int32_t a, int32_t b, uint8_t *status);                                \
    int32_t fx_mul_h##n(int32_t a, int32_t b, uint8_t *status);
FX_SHIFTS(FX_DECLARE)
#undef FX_DECLARE
#endif

/* fx_mul_rs and fx_mul_shr: the assembly entry for a constant shift on the AVR (prefix
 * a or h), the C twin otherwise. */
#if defined(__AVR__)
#define FX_MUL_KERNEL(name, prefix, twin)                                                      \
    FX_INLINE int32_t name(int32_t a, int32_t b, uint8_t s, uint8_t *status)                   \
    {                                                                                          \
        if (__builtin_constant_p(s)) {                                                         \
            switch (s) { FX_SHIFTS(FX_CASE_##prefix) }                                         \
        }                                                                                      \
        return twin(a, b, s, status);                                                          \
    }
#define FX_CASE_a(n)                                                                           \
    case n:                                                                                    \
        return fx_mul_a##n(a, b, status);
#define FX_CASE_h(n)                                                                           \
    case n:                                                                                    \
        return fx_mul_h##n(a, b, status);
#else
#define FX_MUL_KERNEL(name, prefix, twin)                                                      \
    FX_INLINE int32_t name(int32_t a, int32_t b, uint8_t s, uint8_t *status)                   \
    {                                                                                          \
        return twin(a, b, s, status);                                                          \
    }
#endif

/* a · b · 2^-s (1 <= s <= 62), ties away from zero (fx_mul's rounding), saturated. */
FX_MUL_KERNEL(fx_mul_rs, a, fx_mul_rs_c)

/* a · b · 2^-s (1 <= s <= 62), rounded half up, saturated: the hot-loop multiply of
 * STLQF and RLS. */
FX_MUL_KERNEL(fx_mul_shr, h, fx_mul_shr_c)

/* a · b exact in int64: on the AVR the hardware MUL column by column (fx_mul_avr.S, ~60
 * cycles, where avr-gcc's widening multiply calls a library routine of ~200). */
#if defined(__AVR__)
int64_t fx_mul64(int32_t a, int32_t b);
#else
FX_INLINE int64_t fx_mul64(int32_t a, int32_t b) { return (int64_t)a * b; }
#endif

/* a · b · 2^-31 rounded half up, clamped to ±(2^15 - 1) (flagged), as int16: fx_mul_shr(a, b,
 * 31) taken to Q15 (a Cholesky's L_ij from a sum and a reciprocal). On the AVR in one kernel
 * (fx_mul_avr.S: fx_mul64's product, the rounding and the range by its top bytes); the C
 * twin gives the same bits. */
int16_t fx_mul_shr31_q15_c(int32_t a, int32_t b, uint8_t *status);
#if defined(__AVR__)
int16_t fx_mul_shr31_q15(int32_t a, int32_t b, uint8_t *status);
#else
#define fx_mul_shr31_q15 fx_mul_shr31_q15_c
#endif

/* fx_round_shift(a · b, 10), ties away from zero, exact in int64: on the AVR fx_mul64's
 * product rounded and shifted in the same kernel (fx_mul_avr.S, ~30 cycles past the
 * product), where the C calls libgcc's 64-bit shift; the C twin gives the same bits. */
int64_t fx_mul64_rs10_c(int32_t a, int32_t b);
#if defined(__AVR__)
int64_t fx_mul64_rs10(int32_t a, int32_t b);
#else
#define fx_mul64_rs10 fx_mul64_rs10_c
#endif

/* fx_mul_shr for a shift known only at run time, 1 <= s <= 62 (0 outside): on the AVR a
 * jump through a table to the assembly entry for that shift (fx_mul_avr.S), so the product
 * is still ~165 cycles and the same bits. status before s: the entry finds a, b and status
 * where it takes them. */
int32_t fx_mul_shr_n(int32_t a, int32_t b, uint8_t *status, uint8_t s);

/* acc[j] -= fx_mul_shr_n(a, b[j], status, s) for j < n, modulo 2^32: on the AVR the entry
 * for s is looked up once and called for each product (fx_mul_avr.S); the C twin gives the
 * same bits. */
void fx_mul_shr_n_sub_c(int32_t a, uint8_t *status, const int32_t *b, int32_t *acc, uint8_t n,
                        uint8_t s);
#if defined(__AVR__)
void fx_mul_shr_n_sub(int32_t a, uint8_t *status, const int32_t *b, int32_t *acc, uint8_t n,
                      uint8_t s);
#else
#define fx_mul_shr_n_sub fx_mul_shr_n_sub_c
#endif

/* Exact 16 x 16 -> 32 products. On the AVR four hardware MULs inline (~15 cycles), where
 * avr-gcc calls __umulhisi3 or __usmulhisi3 (~25-35 with the call and its moves); the host
 * multiplies. Exact, so both builds give the same bits. */
#if defined(__AVR__)
FX_INLINE uint32_t fx_umul16x16(uint16_t a, uint16_t b)
{
    uint32_t r;
    uint8_t zero;
    __asm__("mul %A2, %A3\n\t"
            "movw %A0, r0\n\t"
            "mul %B2, %B3\n\t"
            "movw %C0, r0\n\t"
            "clr %1\n\t"
            "mul %B2, %A3\n\t"
            "add %B0, r0\n\t"
            "adc %C0, r1\n\t"
            "adc %D0, %1\n\t"
            "mul %A2, %B3\n\t"
            "add %B0, r0\n\t"
            "adc %C0, r1\n\t"
            "adc %D0, %1\n\t"
            "clr r1"
            : "=&r"(r), "=&r"(zero)
            : "r"(a), "r"(b));
    return r;
}

/* a signed, b unsigned (MULSU takes r16-r23: the "a" constraint) */
FX_INLINE int32_t fx_smul16x16(int16_t a, uint16_t b)
{
    int32_t r;
    uint8_t zero;
    __asm__("mul %A2, %A3\n\t"
            "movw %A0, r0\n\t"
            "mulsu %B2, %B3\n\t"
            "movw %C0, r0\n\t"
            "clr %1\n\t"
            "mulsu %B2, %A3\n\t"
            "sbc %D0, %1\n\t"
            "add %B0, r0\n\t"
            "adc %C0, r1\n\t"
            "adc %D0, %1\n\t"
            "mul %A2, %B3\n\t"
            "add %B0, r0\n\t"
            "adc %C0, r1\n\t"
            "adc %D0, %1\n\t"
            "clr r1"
            : "=&r"(r), "=&r"(zero)
            : "a"(a), "a"(b));
    return r;
}

/* both signed */
FX_INLINE int32_t fx_mul16x16(int16_t a, int16_t b)
{
    int32_t r;
    uint8_t zero;
    __asm__("muls %B2, %B3\n\t"
            "movw %C0, r0\n\t"
            "mul %A2, %A3\n\t"
            "movw %A0, r0\n\t"
            "clr %1\n\t"
            "mulsu %B2, %A3\n\t"
            "sbc %D0, %1\n\t"
            "add %B0, r0\n\t"
            "adc %C0, r1\n\t"
            "adc %D0, %1\n\t"
            "mulsu %B3, %A2\n\t"
            "sbc %D0, %1\n\t"
            "add %B0, r0\n\t"
            "adc %C0, r1\n\t"
            "adc %D0, %1\n\t"
            "clr r1"
            : "=&r"(r), "=&r"(zero)
            : "a"(a), "a"(b));
    return r;
}
#else
FX_INLINE uint32_t fx_umul16x16(uint16_t a, uint16_t b) { return (uint32_t)a * b; }
FX_INLINE int32_t fx_smul16x16(int16_t a, uint16_t b) { return (int32_t)a * (int32_t)b; }
FX_INLINE int32_t fx_mul16x16(int16_t a, int16_t b) { return (int32_t)a * b; }
#endif

/* p · 2^-15 rounded half up, for p < 2^31 - 2^14 (a 16 × 16 product by a Q15 fraction): a
 * doubling and a two-byte shift, where the AVR loops on a 15-bit one. */
FX_INLINE uint16_t fx_round_q15(uint32_t p) { return (uint16_t)(((p + 0x4000u) << 1) >> 16); }

/* a · b · 2^-s for an int16 b (1 <= s <= 30), ties away from zero like fx_mul_rs, and the
 * same bits: two 16 × 16 hardware products and byte shifts, no int64. Only a = INT32_MIN,
 * b = INT16_MIN, s = 15 and smaller shifts can leave int32: those saturate (flagged). */
FX_INLINE int32_t fx_mul16(int32_t a, int16_t b, uint8_t s, uint8_t *status)
{
    int16_t ah = (int16_t)((uint32_t)a >> 16);
    uint16_t al = (uint16_t)a;
    /* An empty barrier: GCC, knowing the operands' ranges, would otherwise widen them and
     * call a 32 × 32 multiply instead of the 16 × 16 ones. */
    __asm__("" : "+r"(ah), "+r"(al), "+r"(b));
    /* a · b = H 2^16 + L with L in [0, 2^16): a · b < 0 exactly when H < 0 */
    int32_t hi = (int32_t)ah * b;
    int32_t lo = (int32_t)al * b;
    int32_t H = hi + (lo >> 16);
    uint16_t L = (uint16_t)lo;
    uint8_t neg = H < 0;
    if (s > 16u) { /* floor((H + 2^(s-17) - [L = 0 and negative]) 2^(16-s)) */
        return (H + ((int32_t)1 << (s - 17u)) - (L == 0u && neg)) >> (s - 16u);
    }
    /* H 2^(16-s) + floor((L + 2^(s-1) - neg) 2^-s), the second in [0, 2^(17-s)) */
    uint32_t low = ((uint32_t)L + ((uint32_t)1 << (s - 1u)) - neg) << (16u - s);
    int32_t r;
    if (H > (FX_MAX >> (16u - s)) || H < (FX_MIN >> (16u - s)) ||
        __builtin_add_overflow((int32_t)((uint32_t)H << (16u - s)), (int32_t)(low >> 16), &r)) {
        *status |= STATUS_SATURATED;
        return neg ? FX_MIN : FX_MAX;
    }
    return r;
}

int32_t fx_mul16_c(int32_t a, int16_t b, uint8_t s, uint8_t *status);

/* a · b · 2^-15 rounded half up, for magnitudes: a < 2^31, b <= 2^15 (a Q15 fraction such
 * as |tanh|), so the result stays below 2^31 and nothing saturates. fx_mul16's bits for
 * these operands (ties away from zero is half up on a magnitude), in two unsigned 16 × 16
 * hardware products, a one-bit shift and byte moves: none of fx_mul16's sign handling or
 * range checks. */
FX_INLINE uint32_t fx_umul16_q15(uint32_t a, uint16_t b)
{
    uint16_t ah = (uint16_t)(a >> 16);
    uint16_t al = (uint16_t)a;
    uint32_t hi = fx_umul16x16(ah, b);
    uint32_t lo = fx_umul16x16(al, b); /* < 2^31 - 2^15: doubling it with the half cannot wrap */
    return (hi << 1) + fx_round_q15(lo);
}

uint32_t fx_umul16_q15_c(uint32_t a, uint16_t b);

/* 32 × 24 products for factors kept in Q24 (below 1, or up to 256 from Q16): a b for a < 2^32
 * and b < 2^24 in twelve hardware products, where a run-time shift or a 32 × 32 product
 * costs more than the products themselves. */
#if defined(__AVR__)
/* The product's bytes P1..P6 (P0, below every rounding bit, dropped) summed column by column
 * into T1..T6: each product's low byte into its column, its high byte into the next, the
 * carry into the one after (which holds only carries so far, so nothing is lost). */
#define FX_MUL32X24_COLUMN(lo, hi, c)                                                          \
    "add " lo ", r0\n\t"                                                                       \
    "adc " hi ", r1\n\t"                                                                       \
    "adc " c ", %[z]\n\t"
#define FX_MUL32X24(T1, T2, T3, T4, T5, T6)                                                    \
    "clr %[z]\n\t"                                                                             \
    "clr " T2 "\n\t"                                                                           \
    "clr " T3 "\n\t"                                                                           \
    "clr " T4 "\n\t"                                                                           \
    "clr " T5 "\n\t"                                                                           \
    "clr " T6 "\n\t"                                                                           \
    "mul %A[a], %A[b]\n\t"                                                                     \
    "mov " T1 ", r1\n\t"                                                                       \
    "mul %B[a], %A[b]\n\t" FX_MUL32X24_COLUMN(T1, T2, T3)                                      \
    "mul %A[a], %B[b]\n\t" FX_MUL32X24_COLUMN(T1, T2, T3)                                      \
    "mul %C[a], %A[b]\n\t" FX_MUL32X24_COLUMN(T2, T3, T4)                                      \
    "mul %B[a], %B[b]\n\t" FX_MUL32X24_COLUMN(T2, T3, T4)                                      \
    "mul %A[a], %C[b]\n\t" FX_MUL32X24_COLUMN(T2, T3, T4)                                      \
    "mul %D[a], %A[b]\n\t" FX_MUL32X24_COLUMN(T3, T4, T5)                                      \
    "mul %C[a], %B[b]\n\t" FX_MUL32X24_COLUMN(T3, T4, T5)                                      \
    "mul %B[a], %C[b]\n\t" FX_MUL32X24_COLUMN(T3, T4, T5)                                      \
    "mul %D[a], %B[b]\n\t" FX_MUL32X24_COLUMN(T4, T5, T6)                                      \
    "mul %C[a], %C[b]\n\t" FX_MUL32X24_COLUMN(T4, T5, T6)                                      \
    "mul %D[a], %C[b]\n\t"                                                                     \
    "add " T5 ", r0\n\t"                                                                       \
    "adc " T6 ", r1\n\t" /* P < 2^56: no carry out of P6 */                                    \
    "clr r1\n\t"
/* R (four bytes) plus the top bit of byte B: the product rounded half up below R */
#define FX_ROUND_INTO(B, R)                                                                    \
    "lsl " B "\n\t"                                                                            \
    "adc %A[" R "], %[z]\n\t"                                                                  \
    "adc %B[" R "], %[z]\n\t"                                                                  \
    "adc %C[" R "], %[z]\n\t"                                                                  \
    "adc %D[" R "], %[z]\n\t"
#endif

/* a · b · 2^-24 rounded half up, for a < 2^31 and b < 2^24 (a factor below 1 in Q24): the
 * result is below 2^31 and nothing saturates. */
#if defined(__AVR__)
FX_INLINE uint32_t fx_umul_q24(uint32_t a, uint32_t b)
{
    uint32_t r;
    uint8_t t1, t2, z;
    __asm__(FX_MUL32X24("%[t1]", "%[t2]", "%A[r]", "%B[r]", "%C[r]", "%D[r]")
                FX_ROUND_INTO("%[t2]", "r") /* P's bit 23 */
            : [r] "=&r"(r), [t1] "=&r"(t1), [t2] "=&r"(t2), [z] "=&r"(z)
            : [a] "r"(a), [b] "r"(b));
    return r;
}
#else
FX_INLINE uint32_t fx_umul_q24(uint32_t a, uint32_t b)
{
    return (uint32_t)(((uint64_t)a * b + (UINT32_C(1) << 23)) >> 24);
}
#endif

uint32_t fx_umul_q24_c(uint32_t a, uint32_t b);

/* a · b · 2^-16 for 0 <= b < 2^24 (a factor below 256 in Q16, or below 1 in Q24 taking Q16
 * to Q24): fx_mul_rs(a, b, 16)'s bits (ties away from zero, saturated and flagged), from a
 * 32 × 24 product of |a| where the 32 × 32 kernel takes sixteen products. */
#if defined(__AVR__)
FX_INLINE int32_t fx_mul_q24_rs16(int32_t a, uint32_t b, uint8_t *status)
{
    uint8_t neg = a < 0;
    uint32_t mag = neg ? (uint32_t)0 - (uint32_t)a : (uint32_t)a, r;
    uint8_t t1, t6, z;
    __asm__(FX_MUL32X24("%[t1]", "%A[r]", "%B[r]", "%C[r]", "%D[r]", "%[t6]")
                FX_ROUND_INTO("%[t1]", "r") /* P's bit 15, its carry into P6 */
            "adc %[t6], %[z]"
            : [r] "=&r"(r), [t1] "=&r"(t1), [t6] "=&r"(t6), [z] "=&r"(z)
            : [a] "r"(mag), [b] "r"(b));
    if (t6 != 0u || r > (uint32_t)FX_MAX + neg) {
        *status |= STATUS_SATURATED;
        return neg ? FX_MIN : FX_MAX;
    }
    return neg ? (int32_t)((uint32_t)0 - r) : (int32_t)r;
}
#else
FX_INLINE int32_t fx_mul_q24_rs16(int32_t a, uint32_t b, uint8_t *status)
{
    return fx_mul_rs_c(a, (int32_t)b, 16, status);
}
#endif

int32_t fx_mul_q24_rs16_c(int32_t a, uint32_t b, uint8_t *status);

/* a · b · 2^-15 rounded half up for |b| < 2^15: fx_mul_shr(a, b, 15)'s bits (|a · b| < 2^46
 * cannot saturate), in two 16 × 16 hardware products and byte moves, not a 32 × 32. */
FX_INLINE int32_t fx_mul16_h15(int32_t a, int16_t b)
{
    int16_t ah = (int16_t)((uint32_t)a >> 16);
    uint16_t al = (uint16_t)a;
    __asm__("" : "+r"(ah), "+r"(al), "+r"(b)); /* keep the 16 × 16 products (fx_mul16) */
    int32_t lo = (int32_t)al * b;
    int32_t h = (int32_t)ah * b + (lo >> 16); /* floor(a b 2^-16) */
    /* 2 h + floor((L + 2^14) 2^-15) for the low half L, from L's top two bits */
    uint8_t up = (uint8_t)(((uint8_t)((uint16_t)lo >> 14) + 1u) >> 1);
    return (int32_t)((uint32_t)h << 1) + up;
}

int32_t fx_mul16_h15_c(int32_t a, int16_t b);

/* Σ a[i] b[i] for i < n, int16 pairs summed in int32 (modulo 2^32: the caller keeps the
 * sum in range). On the AVR an assembly loop of hardware multiplies (fx_dot16_avr.S, ~33
 * cycles a pair); the C twin gives the same bits. */
int32_t fx_dot16_c(const int16_t *a, const int16_t *b, uint8_t n);
#if defined(__AVR__)
int32_t fx_dot16(const int16_t *a, const int16_t *b, uint8_t n);
#else
#define fx_dot16 fx_dot16_c
#endif

/* floor(2^31 / l) for 2 <= l < 2^15, exact. On the AVR in assembly (fx_recip_avr.S: the
 * restoring division's steps written out, entered past the quotient's leading zeros); the
 * C twin gives the same quotient. */
uint32_t fx_recip31_c(uint16_t l);
#if defined(__AVR__)
uint32_t fx_recip31(uint16_t l);
#else
#define fx_recip31 fx_recip31_c
#endif

/* floor(sqrt(x)), exact. On the AVR in assembly (fx_isqrt_avr.S: the root's bits by
 * hardware products, unrolled, ~240 cycles where avr-gcc's C takes ~415); the C twin gives
 * the same root. */
uint16_t fx_isqrt32_c(uint32_t x);
#if defined(__AVR__)
uint16_t fx_isqrt32(uint32_t x);
#else
#define fx_isqrt32 fx_isqrt32_c
#endif

/* out[j] = fx_dot16(a, b[j], n) >> shift for j < m (shift < 16, arithmetic): a row of
 * Gram sums in one call. On the AVR in assembly (fx_dot16_avr.S: fx_dot16's loop per
 * sum, without a call and its saves each); the C twin gives the same bits. */
void fx_dot16_rows_c(const int16_t *a, const int16_t *const *b, int32_t *out, uint8_t m,
                     uint8_t n, uint8_t shift);
#if defined(__AVR__)
void fx_dot16_rows(const int16_t *a, const int16_t *const *b, int32_t *out, uint8_t m,
                   uint8_t n, uint8_t shift);
#else
#define fx_dot16_rows fx_dot16_rows_c
#endif

/* in[0..n) · 2^-k rounded half up as int16 (block floating point): the peak to 14 bits, one
 * fewer where rounding would pass limit; a peak below 2^14 shifted up (k <= 0, not held to
 * limit); returns k (0 for zeros). For |in| < 2^30 and 2^13 <= limit < 2^14. On the AVR in assembly (fx_norm16_avr.S, ~29 cycles an
 * entry and ~250 a call); the C twin gives the same bits. */
int8_t fx_norm16_c(const int32_t *in, int16_t *out, uint8_t n, uint16_t limit);
#if defined(__AVR__)
int8_t fx_norm16(const int32_t *in, int16_t *out, uint8_t n, uint16_t limit);
#else
#define fx_norm16 fx_norm16_c
#endif

/* out[i] = Σ band[i][d] c[i + d] over d < 3 and i + d < n (a banded matrix, three words a
 * row, times a vector), int16 products summed in int32 (modulo 2^32: the caller keeps the
 * sums in range). On the AVR in assembly (fx_band16_avr.S, ~94 cycles a row); the C twin
 * gives the same bits. */
void fx_band16_c(const int16_t (*band)[3], const int16_t *c, int32_t *out, uint8_t n);
#if defined(__AVR__)
void fx_band16(const int16_t (*band)[3], const int16_t *c, int32_t *out, uint8_t n);
#else
#define fx_band16 fx_band16_c
#endif

/* Σ l[k stride] y[k] 2^-15 for k < n (int16 l, int32 y): the sum exact, rounded half up
 * once, saturated (flagged). On the AVR an assembly loop of hardware multiplies
 * (fx_dot16x32_avr.S, ~85 cycles a pair); the C twin gives the same bits. */
int32_t fx_dot16x32_q15_c(const int16_t *l, const int32_t *y, uint8_t n, uint8_t stride,
                          uint8_t *status);
#if defined(__AVR__)
int32_t fx_dot16x32_q15(const int16_t *l, const int32_t *y, uint8_t n, uint8_t stride,
                        uint8_t *status);
#else
#define fx_dot16x32_q15 fx_dot16x32_q15_c
#endif

/* A constant factor 0 <= x < 1 kept as a 16-bit mantissa and a shift, x ~ m 2^-sh with m in
 * [2^15, 2^16) (relative error <= 2^-16) and 16 <= sh <= 47; x = 0 gives m = 0. For
 * products in a hot path that need the constant to 16 bits only (each use says why):
 * fx_umul_f costs two unsigned 16 x 16 hardware products and a shift, where an int32
 * multiply costs ~150 cycles. fx_ufactor (configure time) takes x in Q q (q <= 31). */
typedef struct {
    uint16_t m;
    uint8_t sh;
} fx_ufactor_t;

fx_ufactor_t fx_ufactor(uint32_t x, uint8_t q);

/* a m 2^-sh rounded half up, for a < 2^31 (the result is then below 2^31 too). On the AVR
 * an assembly kernel (fx_umul_f_avr.S: eight hardware products and the shift, ~60-90
 * cycles by sh); the C twin below gives the same bits on the host. */
#if defined(__AVR__)
uint32_t fx_umul_f_avr(uint32_t a, uint16_t m, uint8_t sh);
FX_INLINE uint32_t fx_umul_f(uint32_t a, fx_ufactor_t f) { return fx_umul_f_avr(a, f.m, f.sh); }
#else
FX_INLINE uint32_t fx_umul_f(uint32_t a, fx_ufactor_t f)
{
    uint64_t p = (uint64_t)a * f.m;
    return (uint32_t)((p + ((uint64_t)1 << (f.sh - 1u))) >> f.sh);
}
#endif

uint32_t fx_umul_f_c(uint32_t a, uint16_t m, uint8_t sh);

/* x >> n, arithmetic (floor), for a run-time n < 32: whole bytes first, as fx_shr32. */
FX_INLINE int32_t fx_sar32(int32_t x, uint8_t n)
{
    if (n & 16u) {
        x >>= 16;
    }
    if (n & 8u) {
        x >>= 8;
    }
    return x >> (n & 7u);
}

/* a m 2^-sh rounded half up for a signed a (any int32: |a m 2^-sh| < 2^31): fx_umul_f for
 * both signs, inline, in two 16 x 16 hardware products and a shift by bytes, then bits
 * (~70 cycles where an int32 multiply costs ~165 with its call). The same C on both builds. */
FX_INLINE int32_t fx_smul_f(int32_t a, fx_ufactor_t f)
{
    int16_t ah = (int16_t)((uint32_t)a >> 16);
    uint16_t al = (uint16_t)a;
    uint16_t m = f.m;
    uint32_t lo = fx_umul16x16(al, m);
    int32_t h = fx_smul16x16(ah, m) + (int32_t)(lo >> 16); /* floor(a m 2^-16) */
    if (f.sh == 16u) {
        return h + (int32_t)((uint8_t)(lo >> 8) >> 7); /* lo's bit 15, by a byte */
    }
    /* floor((h + 2^(sh-17)) 2^(16-sh)) as ((h >> (sh - 17)) + 1) >> 1 */
    return (fx_sar32(h, (uint8_t)(f.sh - 17u)) + 1) >> 1;
}

int32_t fx_smul_f_c(int32_t a, uint16_t m, uint8_t sh);

/* A signed constant factor of any magnitude below 128 kept to 16 significant bits: f = ±m 2^-sh
 * with m in [2^15, 2^16) (relative error <= 2^-17), 9 <= sh <= 47, the sign in sh's bit 7.
 * A coefficient and its Q conversion in one: a Q_in value times f is the product in Q_out
 * when f = c 2^(q_out - q_in), so one multiply, at a shift chosen at CONFIG, costs a 32 x 16
 * product (fx_mul_f_avr.S) where a coefficient in a fixed Q costs a 32 x 32 one, and a small
 * coefficient keeps its 16 bits whatever its scale (docs/estimators/eso.md).
 * fx_factor (configure time): x 2^e; 0 below 2^-32; at 128 or past it the largest, and
 * STATUS_SATURATED. The same bits on both builds (exact doublings, fx_from_float). */
typedef struct {
    uint16_t m;
    uint8_t sh;
} fx_factor_t;

fx_factor_t fx_factor(float x, int8_t e, uint8_t *status);

/* f's value (configure time), exact in a float. */
float fx_factor_value(fx_factor_t f);

/* a f rounded to nearest, ties away from zero, saturated to int32 (flagged). On the AVR an
 * assembly kernel (fx_mul_f_avr.S: eight hardware products, then a jump to an entry written
 * for f's shift, ~104 cycles); the C twin gives the same bits on the host. */
int32_t fx_mul_f_c(int32_t a, uint16_t m, uint8_t sh, uint8_t *status);
#if defined(__AVR__)
int32_t fx_mul_f_avr(int32_t a, uint16_t m, uint8_t sh, uint8_t *status);
FX_INLINE int32_t fx_mul_f(int32_t a, fx_factor_t f, uint8_t *status)
{
    return fx_mul_f_avr(a, f.m, f.sh, status);
}
#else
FX_INLINE int32_t fx_mul_f(int32_t a, fx_factor_t f, uint8_t *status)
{
    return fx_mul_f_c(a, f.m, f.sh, status);
}
#endif

/* A factor and, on the AVR, the word address of fx_mul_f_avr.S's entry for its shift: the
 * assembly steps (fx_step_avr.inc's MULX) multiply inline and call the entry directly, where
 * fx_mul_f_avr's call and its table lookup cost ~16 cycles a product. The C twins read f.
 * fx_xfactor (configure time): fx_factor's f; entry 0 on the host. */
typedef struct {
    fx_factor_t f;
    uint16_t entry;
} fx_xfactor_t;

fx_xfactor_t fx_xfactor(float x, int8_t e, uint8_t *status);

/* a (qa) * b (qb) -> q_out, ties away from zero; qa + qb <= q_out (no fraction bit to
 * drop) or a shift past 62 goes through int64 (fx_mul_wide). */
int32_t fx_mul_wide(int32_t a, uint8_t qa, int32_t b, uint8_t qb, uint8_t q_out, uint8_t *status);

FX_INLINE int32_t fx_mul(int32_t a, uint8_t qa, int32_t b, uint8_t qb, uint8_t q_out,
                             uint8_t *status)
{
    int8_t s = (int8_t)(qa + qb - q_out);
    return s >= 1 && s <= 62 ? fx_mul_rs(a, b, (uint8_t)s, status)
                             : fx_mul_wide(a, qa, b, qb, q_out, status);
}

/* a (qa) / b (qb) -> q_out; b == 0 saturates towards a's sign and flags STATUS_SINGULAR. */
int32_t fx_div(int32_t a, uint8_t qa, int32_t b, uint8_t qb, uint8_t q_out, uint8_t *status);

/* Division through a reciprocal, for hot paths (fx_div is exact but ~1,800 cycles on the
 * AVR: an int64 division). fx_recip(b), b > 0: y in Q29 (1 <= y 2^-29 <= 2) and n with
 * 1/b = y 2^(n - 60), from a 33-entry table and one Newton step (relative error < 5e-7).
 * fx_div_by: a (qa) / b (qb) -> q_out given b's reciprocal, rounded half up on the
 * magnitude, saturated; ~3 multiplies for the reciprocal and 1 per quotient. */
typedef struct {
    int32_t y;
    uint8_t n;
} fx_recip_t;

fx_recip_t fx_recip(int32_t b);

/* 1/b for b > 0 to 16 bits, where a product by it needs no more (a gain in a covariance
 * update): r in [2^15, 2^16) and n with 1/b = r 2^(n - 46), relative error < 5e-5; the
 * table's seed and one Newton step in 16 x 16 hardware products (~150 cycles). */
typedef struct {
    uint16_t r;
    uint8_t n;
} fx_recip16_t;

fx_recip16_t fx_recip16(int32_t b);
int32_t fx_div_by(int32_t a, uint8_t qa, fx_recip_t r, uint8_t qb, uint8_t q_out,
                  uint8_t *status);

/* a from q_in to q_out, ties away from zero, saturated; int32 only (a shift of whole
 * bytes costs a few moves on the AVR, any other a short loop). */
FX_INLINE int32_t fx_rescale(int32_t a, uint8_t q_in, uint8_t q_out, uint8_t *status)
{
    if (q_in > q_out) {
        uint8_t d = (uint8_t)(q_in - q_out);
        if (d > 31u) {
            return fx_sat(fx_round_shift(a, (int8_t)d), status);
        }
        /* floor, then one up past the half (at the half too for a >= 0): floor((low + half
         * - [a < 0]) 2^-d) for the low d bits, in 16 bits where they fit (two bytes of
         * arithmetic on the AVR, not a 32-bit compare) */
        if (d <= 15u) {
            uint16_t low = (uint16_t)((uint16_t)a & ((1u << d) - 1u));
            return (a >> d) + (int32_t)((uint16_t)(low + (1u << (d - 1u)) - (a < 0)) >> d);
        }
        uint32_t half = (uint32_t)1 << (d - 1u);
        uint32_t low = (uint32_t)a & ((half << 1) - 1u);
        return (a >> d) + (low >= half + (a < 0 ? 1u : 0u) ? 1 : 0);
    }
    uint8_t u = (uint8_t)(q_out - q_in);
    if (u > 31u) {
        return fx_sat(fx_round_shift(a, (int8_t)-u), status);
    }
    if (a > (FX_MAX >> u) || a < (FX_MIN >> u)) {
        *status |= STATUS_SATURATED;
        return a < 0 ? FX_MIN : FX_MAX;
    }
    return (int32_t)((uint32_t)a << u);
}

int32_t fx_rescale_c(int32_t a, uint8_t q_in, uint8_t q_out, uint8_t *status);

/* tanh of |x| in Q15 from |x| in Q19 (16ths of the table's grid with 15 fraction bits),
 * pos < 64 · 2^15: the table's interpolation, a 16 × 16 product and byte shifts. */
uint16_t fx_tanh_q15_pos(uint32_t pos);

/* The same in cell idx < 64 at frac < 2^15 of it (pos = idx 2^15 + frac). */
uint16_t fx_tanh_q15_cell(uint8_t idx, uint16_t frac);

/* The cell of a 1/16 grid that a magnitude in qx (19 < qx <= 27) falls in, *idx = mag 2^(4 -
 * qx), and the fraction of it, mag 2^(19 - qx) mod 2^15 (Q15), by bytes and short shifts (the
 * AVR loops on a 32-bit shift that is not whole bytes). */
FX_INLINE uint16_t fx_grid16_cell(uint32_t mag, uint8_t qx, uint8_t *idx)
{
    uint8_t s = (uint8_t)(qx - 19u);
    *idx = (uint8_t)((uint16_t)(mag >> 16) >> (s - 1u));
    return (uint16_t)((uint16_t)((uint16_t)(mag >> 8) << (8u - s)) | (uint8_t)((uint8_t)mag >> s)) &
           0x7fffu;
}

/* tanh(x) for x in qx (4 <= qx <= 31) -> q_out (15 <= q_out <= 30): a 65-entry Q15 table
 * over [0, 4] with linear interpolation; |error| <= 7e-4 for every x (3.92e-4 inside
 * [-4, 4], tanh(4)'s distance to 1 beyond). With qx and q_out constants, the conversions
 * are constant shifts. */
/* tanh(|x|) in Q15 for a magnitude |x| in qx (4 <= qx <= 31): fx_tanh without the sign. */
FX_INLINE uint16_t fx_tanh_abs_q15(uint32_t mag, uint8_t qx)
{
    if (mag >= (uint32_t)64 << (qx - 4u)) {
        return 32746; /* tanh(4), the table's last entry */
    }
    if (qx > 19u && qx <= 27u) {
        uint8_t idx;
        uint16_t frac = fx_grid16_cell(mag, qx, &idx);
        return fx_tanh_q15_cell(idx, frac);
    }
    return fx_tanh_q15_pos(qx >= 19u ? mag >> (qx - 19u) : mag << (19u - qx));
}

uint16_t fx_tanh_abs_q15_c(uint32_t mag, uint8_t qx);

FX_INLINE int32_t fx_tanh(int32_t x, uint8_t qx, uint8_t q_out)
{
    uint32_t mag = x < 0 ? (uint32_t)0 - (uint32_t)x : (uint32_t)x;
    int32_t y = (int32_t)((uint32_t)fx_tanh_abs_q15(mag, qx) << (q_out - 15u));
    return x < 0 ? -y : y;
}

/* tanh for float32 without libm's (~3,300 cycles on the AVR; ~300 here): a cubic Hermite
 * through tanh(k / 16) in Q16 with the exact slopes 1 - y², and a table of its tail to 9;
 * |error| < 3e-5 (tests/native/test_fixmath.py). The same bits on both builds. */
float tanh_f32(float x);

/* sqrt(a) for a >= 0, both in q (negative input: 0 and STATUS_CLAMPED). */
int32_t fx_sqrt(int32_t a, uint8_t q, uint8_t *status);

/* Appended for seed 003 (configure-time conversions, not for a step's hot path). */

/* round(x * 2^q) saturated to int32 (NaN gives 0 and STATUS_NOT_FINITE); q <= 62.
 * Only multiplications by 2 and one rounding: the AVR and the host give the same bits. */
int32_t fx_from_float(float x, uint8_t q, uint8_t *status);

/* cos ε and sin ε in Q30 for a small angle ε (Q30, |ε| <= 0.1 rad) from their series:
 * libm's last bit differs between avr-libc and the host, and FIXED needs the same bits. */
void fx_small_cos_sin_q30(int32_t eps, int32_t *c, int32_t *s, uint8_t *status);

/* asin x in Q30 for x in Q30, |x| <= 1 (past it: clamped, STATUS_CLAMPED): its series to
 * x⁹ up to 1/2, error < 1e-5 rad, and past 1/2 π/2 - 2 asin sqrt((1 - x)/2). */
int32_t fx_asin_q30(int32_t x, uint8_t *status);

/* log2(x · 2^-q) in Q24 for x > 0 (x <= 0 gives INT32_MIN): the leading bit's position
 * and a 17-entry table with linear interpolation, |error| < 1e-3. On the AVR in assembly
 * (fx_log2_avr.S, ~130 cycles where avr-gcc's C takes ~255); the C twin gives the same bits. */
int32_t fx_log2_q24_c(int32_t x, uint8_t q);
#if defined(__AVR__)
int32_t fx_log2_q24(int32_t x, uint8_t q);
#else
#define fx_log2_q24 fx_log2_q24_c
#endif

#ifdef __cplusplus
}
#endif

#endif
