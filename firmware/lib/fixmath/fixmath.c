#include "fixmath/fixmath.h"

#include <string.h>

#include "rom/rom.h"

int32_t fx_sat(int64_t x, uint8_t *status)
{
    if (x > FX_MAX) {
        *status |= STATUS_SATURATED;
        return FX_MAX;
    }
    if (x < FX_MIN) {
        *status |= STATUS_SATURATED;
        return FX_MIN;
    }
    return (int32_t)x;
}

int64_t fx_round_shift(int64_t x, int8_t shift)
{
    if (shift <= 0) {
        return x * ((int64_t)1 << -shift); /* callers keep |x| small enough to widen */
    }
    /* Round the magnitude so ties go away from zero on both signs; no reliance on
     * how >> treats negative numbers. */
    uint64_t m = x < 0 ? (uint64_t)0 - (uint64_t)x : (uint64_t)x;
    m = (m + ((uint64_t)1 << (shift - 1))) >> shift;
    return x < 0 ? -(int64_t)m : (int64_t)m;
}

int16_t fx_mul_shr31_q15_c(int32_t a, int32_t b, uint8_t *status)
{
    int64_t r = ((int64_t)a * b + ((int64_t)1 << 30)) >> 31; /* |a b| < 2^62: no wrap */
    if (r > INT16_MAX || r < -INT16_MAX) {
        *status |= STATUS_SATURATED;
        return r > 0 ? INT16_MAX : -INT16_MAX;
    }
    return (int16_t)r;
}

void fx_mul_shr_n_sub_c(int32_t a, uint8_t *status, const int32_t *b, int32_t *acc, uint8_t n,
                        uint8_t s)
{
    for (uint8_t j = 0; j < n; j++) {
        acc[j] = (int32_t)((uint32_t)acc[j] - (uint32_t)fx_mul_shr_n(a, b[j], status, s));
    }
}

int64_t fx_mul64_rs10_c(int32_t a, int32_t b) { return fx_round_shift((int64_t)a * b, 10); }

int32_t fx_mul_wide(int32_t a, uint8_t qa, int32_t b, uint8_t qb, uint8_t q_out, uint8_t *status)
{
    return fx_sat(fx_round_shift((int64_t)a * b, (int8_t)(qa + qb - q_out)), status);
}

/* The twins of fx_mul_avr.S. Ties away from zero as floor((p + 2^(s-1) - [p < 0]) 2^-s):
 * the same as rounding |p| half up, in one add. GCC and clang shift a negative int64
 * arithmetically. */
int32_t fx_mul_rs_c(int32_t a, int32_t b, uint8_t s, uint8_t *status)
{
    int64_t p = (int64_t)a * b;
    return fx_sat((p + ((int64_t)1 << (s - 1u)) - (p < 0)) >> s, status);
}

#if !defined(__AVR__) /* the AVR's is fx_mul_avr.S's table */
int32_t fx_mul_shr_n(int32_t a, int32_t b, uint8_t *status, uint8_t s)
{
    return s >= 1u && s <= 62u ? fx_mul_shr_c(a, b, s, status) : 0;
}
#endif

/* fx_mul16 out of line, for the native tests (tests/native/test_fixmath.py) to call. */
int32_t fx_mul16_c(int32_t a, int16_t b, uint8_t s, uint8_t *status)
{
    return fx_mul16(a, b, s, status);
}

/* fx_umul16_q15 out of line, for the native tests. */
uint32_t fx_umul16_q15_c(uint32_t a, uint16_t b) { return fx_umul16_q15(a, b); }

/* fx_rescale and fx_tanh_abs_q15 out of line, for the native tests. */
int32_t fx_rescale_c(int32_t a, uint8_t q_in, uint8_t q_out, uint8_t *status)
{
    return fx_rescale(a, q_in, q_out, status);
}

uint16_t fx_tanh_abs_q15_c(uint32_t mag, uint8_t qx) { return fx_tanh_abs_q15(mag, qx); }

/* fx_umul_q24 and fx_mul_q24_rs16 out of line, for the native tests. */
uint32_t fx_umul_q24_c(uint32_t a, uint32_t b) { return fx_umul_q24(a, b); }

int32_t fx_mul_q24_rs16_c(int32_t a, uint32_t b, uint8_t *status)
{
    return fx_mul_q24_rs16(a, b, status);
}

int32_t fx_dot16x32_q15_c(const int16_t *l, const int32_t *y, uint8_t n, uint8_t stride,
                          uint8_t *status)
{
    int64_t sum = 0; /* n products below 2^46 */
    for (uint8_t k = 0; k < n; k++) {
        sum += (int64_t)l[k * stride] * y[k];
    }
    return fx_sat((sum + ((int64_t)1 << 14)) >> 15, status);
}

/* fx_mul16_h15 out of line, for the native tests. */
int32_t fx_mul16_h15_c(int32_t a, int16_t b) { return fx_mul16_h15(a, b); }

int32_t fx_dot16_c(const int16_t *a, const int16_t *b, uint8_t n)
{
    uint32_t acc = 0; /* modulo 2^32, as the AVR's bytes */
    for (uint8_t i = 0; i < n; i++) {
        acc += (uint32_t)((int32_t)a[i] * b[i]);
    }
    return (int32_t)acc;
}

/* count more quotient bits of a restoring division by l, the remainder (below l < 2^15)
 * in 16 bits */
static inline uint16_t quotient_bits(uint16_t *rem, uint16_t l, uint8_t count)
{
    uint16_t q = 0, r = *rem;
    for (; count != 0u; count--) {
        r = (uint16_t)(r << 1);
        q = (uint16_t)(q << 1);
        if (r >= l) {
            r = (uint16_t)(r - l);
            q |= 1u;
        }
    }
    *rem = r;
    return q;
}

/* floor(2^31 / l) for 2 <= l < 2^15, restoring division with the remainder (below l) in
 * 16 bits: the dividend's bits after its leading one are zeros, so the doublings before
 * the quotient's first bit need no quotient (the first few taken at once), and the
 * quotient is built in two 16-bit halves. */
uint32_t fx_recip31_c(uint16_t l)
{
    uint16_t rem = 1;
    uint8_t left = 31;
    if (l > 4096u) {
        rem = 4096;
        left = 19;
    } else if (l > 256u) {
        rem = 256;
        left = 23;
    }
    while (left != 0u && (uint16_t)(rem << 1) < l) {
        rem = (uint16_t)(rem << 1);
        left--;
    }
    uint8_t low = left > 16u ? 16u : left;
    uint16_t hi = quotient_bits(&rem, l, (uint8_t)(left - low));
    return (uint32_t)hi << 16 | quotient_bits(&rem, l, low);
}

/* The root's bits from the top, each kept where the root so far squared stays at most x;
 * its high byte from x's top half by 8 × 8 products (floor(sqrt(x)) >> 8 is
 * floor(sqrt(x >> 16))), its low byte by 16 × 16 ones. */
uint16_t fx_isqrt32_c(uint32_t x)
{
    uint16_t top = (uint16_t)(x >> 16);
    uint8_t hi = 0;
    for (uint8_t bit = 0x80u; bit != 0u; bit >>= 1) {
        uint8_t t = (uint8_t)(hi | bit);
        hi = (uint16_t)((uint16_t)t * t) <= top ? t : hi;
    }
    uint16_t root = (uint16_t)((uint16_t)hi << 8);
    for (uint8_t bit = 0x80u; bit != 0u; bit >>= 1) {
        uint16_t t = (uint16_t)(root | bit);
        root = fx_umul16x16(t, t) <= x ? t : root;
    }
    return root;
}

void fx_dot16_rows_c(const int16_t *a, const int16_t *const *b, int32_t *out, uint8_t m,
                     uint8_t n, uint8_t shift)
{
    for (uint8_t j = 0; j < m; j++) {
        out[j] = fx_dot16_c(a, b[j], n) >> shift; /* arithmetic, as the AVR's */
    }
}

void fx_band16_c(const int16_t (*band)[3], const int16_t *c, int32_t *out, uint8_t n)
{
    for (uint8_t i = 0; i < n; i++) {
        uint32_t acc = 0; /* modulo 2^32, as the AVR's bytes */
        for (uint8_t d = 0; d < 3u && i + d < n; d++) {
            acc += (uint32_t)((int32_t)band[i][d] * c[i + d]);
        }
        out[i] = (int32_t)acc;
    }
}

int8_t fx_norm16_c(const int32_t *in, int16_t *out, uint8_t n, uint16_t limit)
{
    uint32_t peak = 0;
    for (uint8_t i = 0; i < n; i++) {
        uint32_t mag = in[i] < 0 ? (uint32_t)0 - (uint32_t)in[i] : (uint32_t)in[i];
        peak = mag > peak ? mag : peak;
    }
    uint8_t bits = 0;
    while (bits < 32u && (peak >> bits) != 0u) {
        bits++;
    }
    int8_t k = peak != 0u ? (int8_t)(bits - 14) : 0;
    if (k <= 0) { /* |in| < 2^14 */
        for (uint8_t i = 0; i < n; i++) {
            out[i] = (int16_t)(uint16_t)((uint32_t)in[i] << -k);
        }
        return k;
    }
    if (peak >= ((uint32_t)2u * limit + 1u) << (k - 1)) { /* rounding up would pass it */
        k++;
    }
    int32_t half = (int32_t)1 << (k - 1);
    for (uint8_t i = 0; i < n; i++) { /* GCC shifts a negative int32 arithmetically */
        out[i] = (int16_t)(uint16_t)(uint32_t)((in[i] + half) >> k);
    }
    return k;
}

fx_ufactor_t fx_ufactor(uint32_t x, uint8_t q)
{
    if (x == 0u) {
        return (fx_ufactor_t){.m = 0, .sh = 16};
    }
    uint8_t top = 31; /* x's leading bit */
    while (!(x >> top)) {
        top--;
    }
    if (top <= 15u) {
        return (fx_ufactor_t){.m = (uint16_t)(x << (15u - top)), .sh = (uint8_t)(q + 15u - top)};
    }
    uint8_t d = (uint8_t)(top - 15u);
    uint32_t m = (x + ((uint32_t)1 << (d - 1u))) >> d; /* rounded half up */
    uint8_t sh = (uint8_t)(q + 15u - top);
    if (m == 0x10000u) { /* rounded up to the next power of two */
        m = 0x8000u;
        sh--;
    }
    if (sh < 16u) { /* x within 2^-17 of 1: the largest mantissa */
        return (fx_ufactor_t){.m = 0xffffu, .sh = 16};
    }
    return (fx_ufactor_t){.m = (uint16_t)m, .sh = sh};
}

/* fx_umul_f and fx_smul_f out of line, for the native tests. */
uint32_t fx_umul_f_c(uint32_t a, uint16_t m, uint8_t sh)
{
    return fx_umul_f(a, (fx_ufactor_t){.m = m, .sh = sh});
}

int32_t fx_smul_f_c(int32_t a, uint16_t m, uint8_t sh)
{
    return fx_smul_f(a, (fx_ufactor_t){.m = m, .sh = sh});
}

fx_factor_t fx_factor(float x, int8_t e, uint8_t *status)
{
    uint8_t neg = x < 0.0f;
    float u = neg ? -x : x;
    if (!(u > 0.0f) || u > 3.0e38f) { /* 0, or not finite: fx_from_float flags NaN */
        (void)fx_from_float(u, 0, status);
        return (fx_factor_t){.m = 0, .sh = 16};
    }
    int16_t sh = (int16_t)(16 - e); /* u in [1/2, 1) by exact halvings and doublings */
    while (u >= 1.0f) {
        u *= 0.5f;
        sh--;
    }
    while (u < 0.5f) {
        u *= 2.0f;
        sh++;
    }
    int32_t m = fx_from_float(u, 16, status); /* [2^15, 2^16] */
    if (m == 0x10000) {
        m = 0x8000;
        sh--;
    }
    if (sh > 47) { /* below 2^-32: its products round to 0 or +-1 */
        return (fx_factor_t){.m = 0, .sh = 16};
    }
    if (sh < 9) {
        *status |= STATUS_SATURATED;
        m = 0xffff;
        sh = 9;
    }
    return (fx_factor_t){.m = (uint16_t)m, .sh = (uint8_t)((uint8_t)sh | (neg ? 0x80u : 0u))};
}

float fx_factor_value(fx_factor_t f)
{
    float v = (float)f.m;
    for (uint8_t i = f.sh & 0x3fu; i > 0u; i--) {
        v *= 0.5f;
    }
    return (f.sh & 0x80u) ? -v : v;
}

#if defined(__AVR__)
uint16_t fx_mul_f_entry(uint8_t sh); /* fx_mul_f_avr.S */
#endif

fx_xfactor_t fx_xfactor(float x, int8_t e, uint8_t *status)
{
    fx_xfactor_t xf = {fx_factor(x, e, status), 0};
#if defined(__AVR__)
    xf.entry = fx_mul_f_entry(xf.f.sh);
#endif
    return xf;
}

int32_t fx_mul_f_c(int32_t a, uint16_t m, uint8_t sh, uint8_t *status)
{
    uint8_t s = sh & 0x3fu;
    uint64_t p = (uint64_t)(a < 0 ? 0u - (uint32_t)a : (uint32_t)a) * m;
    p = (p + ((uint64_t)1 << (s - 1u))) >> s; /* the magnitude, rounded half up */
    if ((a < 0) != ((sh & 0x80u) != 0u)) {
        if (p > 0x80000000u) {
            *status |= STATUS_SATURATED;
            return FX_MIN;
        }
        return (int32_t)(0u - (uint32_t)p);
    }
    if (p > 0x7fffffffu) {
        *status |= STATUS_SATURATED;
        return FX_MAX;
    }
    return (int32_t)p;
}

int32_t fx_mul_shr_c(int32_t a, int32_t b, uint8_t s, uint8_t *status)
{
    return fx_sat(((int64_t)a * b + ((int64_t)1 << (s - 1u))) >> s, status);
}

int32_t fx_div(int32_t a, uint8_t qa, int32_t b, uint8_t qb, uint8_t q_out, uint8_t *status)
{
    if (b == 0) {
        *status |= STATUS_SINGULAR;
        return a < 0 ? FX_MIN : FX_MAX;
    }
    /* result = a * 2^(q_out + qb - qa) / b, rounded: widen the numerator first. */
    int8_t up = (int8_t)(q_out + qb - qa);
    uint32_t n32 = a < 0 ? (uint32_t)0 - (uint32_t)a : (uint32_t)a;
    uint32_t d32 = b < 0 ? (uint32_t)0 - (uint32_t)b : (uint32_t)b;
    if (up >= 0 && up <= 30 && n32 < d32) {
        /* |a| < |b|: the quotient is below 2^up + 1, its bits those of the up zeros after
         * |a|, a restoring division with the remainder (below |b|) in 32 bits, where the
         * AVR's 64-bit division takes ~1,200 cycles; rounded half up as the 64-bit path */
        uint32_t q = 0;
        for (int8_t i = 0; i < up; i++) {
            n32 <<= 1;
            q <<= 1;
            if (n32 >= d32) {
                n32 -= d32;
                q |= 1u;
            }
        }
        q += n32 >= d32 - d32 / 2u ? 1u : 0u;
        return (a < 0) != (b < 0) ? -(int32_t)q : (int32_t)q;
    }
    int64_t num = up >= 0 ? (int64_t)a * ((int64_t)1 << up) : fx_round_shift(a, (int8_t)-up);
    uint64_t n = num < 0 ? (uint64_t)0 - (uint64_t)num : (uint64_t)num;
    uint64_t d = b < 0 ? (uint64_t)0 - (uint64_t)(int64_t)b : (uint64_t)b;
    uint64_t q = (n + d / 2u) / d;
    int negative = (num < 0) != (b < 0);
    if (q > (uint64_t)FX_MAX + (negative ? 1u : 0u)) {
        *status |= STATUS_SATURATED;
        return negative ? FX_MIN : FX_MAX;
    }
    return negative ? (int32_t)(-(int64_t)q) : (int32_t)q;
}

/* 2 / (1 + k / 32) in Q14, k = 0..32: 1/x on x in [1/2, 1]. */
static const ROM ROM_TABLE(uint16_t, 33) recip_table = {{
    32768, 31775, 30840, 29959, 29127, 28340, 27594, 26887, 26214, 25575, 24966,
    24385, 23831, 23302, 22795, 22310, 21845, 21400, 20972, 20560, 20165, 19784,
    19418, 19065, 18725, 18396, 18079, 17772, 17476, 17190, 16913, 16644, 16384,
}};

/* Shifts v (> 0) until bit 30 is its top bit; returns by how much to the left (-1: 2^31,
 * the magnitude of INT32_MIN, shifted right). A binary search by 16, 8, 4, 2 and 1 bits:
 * the AVR shifts an int32 one bit at a time, so whole bytes go first and no loop runs. */
static int8_t normalize30(uint32_t *v)
{
    uint32_t x = *v;
    int8_t n = 0;
    if (x & 0x80000000u) {
        *v = x >> 1;
        return -1;
    }
    if (!(x & 0xffff8000u)) { /* top bit <= 14 */
        x <<= 16;
        n = 16;
    }
    if (!(x & 0xff800000u)) { /* <= 22 */
        x <<= 8;
        n = (int8_t)(n + 8);
    }
    if (!(x & 0xf8000000u)) { /* <= 26 */
        x <<= 4;
        n = (int8_t)(n + 4);
    }
    if (!(x & 0xe0000000u)) { /* <= 28 */
        x <<= 2;
        n = (int8_t)(n + 2);
    }
    if (!(x & 0x40000000u)) { /* 29 */
        x <<= 1;
        n++;
    }
    *v = x;
    return n;
}

/* 1/x for x (normalised, x 2^-31 in [1/2, 1)) from the table, interpolated: Q29, within
 * 2e-3 of 1/x. */
static int32_t recip_seed(uint32_t x)
{
    uint8_t k = (uint8_t)((uint8_t)(x >> 24) >> 1) & 31u; /* (x >> 25) by bytes */
    /* the next 16 bits, (x >> 9) by bytes and one 16-bit shift (GCC loops nine times) */
    uint16_t f = (uint16_t)((uint16_t)(x >> 8) >> 1 | (uint16_t)((uint8_t)(x >> 24) & 1u) << 15);
    uint16_t lo = rom_u16(ROM_AT(recip_table, k));
    uint16_t d = (uint16_t)(lo - rom_u16(ROM_AT(recip_table, k + 1u)));
    return (int32_t)(((uint32_t)lo << 16 >> 1) - (fx_umul16x16(d, f) >> 1));
}

fx_recip16_t fx_recip16(int32_t b)
{
    uint32_t x = (uint32_t)b;
    uint8_t n = (uint8_t)normalize30(&x);
    int32_t y0 = recip_seed(x);
    /* y0 and x to 16 bits (y0 <= 2^30: 2^30 itself, x = 2^30, would not fit) */
    /* (y0 >> 14) as (y0 << 2) >> 16: the AVR shifts by whole bytes for free, else loops */
    uint16_t y = (uint16_t)(((uint32_t)(y0 < (INT32_C(1) << 30) ? y0 : (INT32_C(1) << 30) - 1) << 2) >> 16);
    uint16_t u = (uint16_t)((x << 1) >> 16); /* x 2^-15, floor */
    /* one Newton step y (2 - u y): u y in Q31 is within 2e-3 of 1, so 2^31 - u y < 2^22 */
    int16_t e = (int16_t)((int32_t)(UINT32_C(0x80000000) - fx_umul16x16(u, y)) >> 8);
    /* (e y) >> 23 as ((e y) << 1) >> 24 (|e y| < 2^30) */
    int32_t r = (int32_t)y + ((int32_t)((uint32_t)fx_smul16x16(e, y) << 1) >> 24);
    return (fx_recip16_t){.r = r > 0xffff ? 0xffffu : (uint16_t)r, .n = n};
}

fx_recip_t fx_recip(int32_t b)
{
    uint32_t x = (uint32_t)b; /* x 2^-31 in [1/2, 1) once normalised */
    uint8_t n = (uint8_t)normalize30(&x); /* b <= INT32_MAX: a left shift */
    int32_t y = recip_seed(x); /* Q29 */
    uint8_t st = 0; /* nothing here can saturate: x y is within 1e-3 of 1 */
    int32_t t = fx_mul_rs((int32_t)x, y, 31, &st);            /* x y, Q29 */
    y = fx_mul_rs(y, ((int32_t)1 << 30) - t, 29, &st);       /* y (2 - x y) */
    return (fx_recip_t){.y = y, .n = n};
}

int32_t fx_div_by(int32_t a, uint8_t qa, fx_recip_t r, uint8_t qb, uint8_t q_out,
                  uint8_t *status)
{
    if (a == 0) {
        return 0;
    }
    uint32_t m = a < 0 ? (uint32_t)0 - (uint32_t)a : (uint32_t)a;
    int8_t k = normalize30(&m);
    /* |a| / b = q 2^(n - k - 29) with q = m y 2^-31 in [2^28, 2^30] */
    uint32_t q = (uint32_t)fx_mul_rs((int32_t)m, r.y, 31, status);
    int16_t sh = (int16_t)((int16_t)r.n - k - 29 + qb - qa + q_out);
    if (sh >= 0) {
        if (sh > 30 || q > fx_shr32((uint32_t)FX_MAX, (uint8_t)sh)) {
            *status |= STATUS_SATURATED;
            return a < 0 ? FX_MIN : FX_MAX;
        }
        q = fx_shl32(q, (uint8_t)sh);
    } else {
        uint8_t down = (uint8_t)-sh;
        if (down > 31u) {
            return 0;
        }
        /* (q + 2^(down-1)) >> down, q <= 2^30, as ((q >> (down-1)) + 1) >> 1 */
        q = (fx_shr32(q, (uint8_t)(down - 1u)) + 1u) >> 1;
    }
    return a < 0 ? -(int32_t)q : (int32_t)q;
}

int32_t fx_sqrt(int32_t a, uint8_t q, uint8_t *status)
{
    if (a <= 0) {
        if (a < 0) {
            *status |= STATUS_CLAMPED;
        }
        return 0;
    }
    /* sqrt(a * 2^q) in integers gives the result in q; bit-by-bit, exact floor, then round. */
    uint64_t n = (uint64_t)a << q;
    uint64_t root = 0;
    uint64_t bit = (uint64_t)1 << 62;
    while (bit > n) {
        bit >>= 2;
    }
    while (bit != 0) {
        if (n >= root + bit) {
            n -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    if (n > root) { /* remainder above root means the true root is past root + 0.5 */
        root++;
    }
    return fx_sat((int64_t)root, status);
}

/* tanh(k / 16) in Q15, k = 0..64. */
static const ROM ROM_TABLE(uint16_t, 65) tanh_table = {{
    0,     2045,  4075,  6073,  8025,  9919,  11743, 13486, 15143, 16706, 18173, 19542, 20813,
    21986, 23066, 24054, 24956, 25776, 26519, 27191, 27797, 28341, 28830, 29268, 29660, 30010,
    30322, 30600, 30847, 31067, 31262, 31435, 31589, 31726, 31846, 31953, 32048, 32132, 32206,
    32271, 32329, 32381, 32426, 32466, 32501, 32532, 32560, 32584, 32606, 32625, 32642, 32657,
    32670, 32681, 32691, 32700, 32708, 32715, 32721, 32727, 32732, 32736, 32740, 32743, 32746,
}};

uint16_t fx_tanh_q15_cell(uint8_t idx, uint16_t frac)
{
    uint16_t lo = rom_u16(ROM_AT(tanh_table, idx));
    uint16_t d = (uint16_t)(rom_u16(ROM_AT(tanh_table, idx + 1u)) - lo);
    /* (d · frac + 2^14) >> 15, as a doubling and a two-byte shift */
    return (uint16_t)(lo + (uint16_t)(((fx_umul16x16(d, frac) + 0x4000u) << 1) >> 16));
}

uint16_t fx_tanh_q15_pos(uint32_t pos)
{
    /* pos >> 15 and the low 15 bits, by whole bytes (the AVR loops on other shifts) */
    uint8_t idx = (uint8_t)((uint8_t)(pos >> 16) << 1 | (uint8_t)((uint16_t)pos >> 15));
    return fx_tanh_q15_cell(idx, (uint16_t)pos & 0x7fffu);
}

/* tanh(k / 16) in Q16, k = 0..64: tanh_f32's nodes. */
static const ROM ROM_TABLE(uint16_t, 65) tanh_q16 = {{
    0,     4091,  8150,  12146, 16051, 19838, 23485, 26973, 30285, 33412, 36346, 39084, 41625,
    43972, 46131, 48108, 49912, 51552, 53038, 54382, 55593, 56683, 57660, 58536, 59320, 60019,
    60643, 61199, 61694, 62134, 62524, 62871, 63179, 63451, 63693, 63907, 64096, 64263, 64412,
    64543, 64659, 64761, 64852, 64932, 65003, 65065, 65120, 65169, 65212, 65250, 65283, 65313,
    65339, 65362, 65383, 65401, 65417, 65431, 65443, 65454, 65464, 65472, 65480, 65486, 65492,
}};

/* 1 - tanh(4 + k / 4) in Q32, k = 0..20: its tail up to 9, past which float32 rounds to 1. */
static const ROM ROM_TABLE(uint32_t, 21) tanh_tail_q32 = {{
    2880636, 1747424, 1059951, 642924, 389965, 236530, 143464, 87016, 52778, 32012, 19416,
    11776,   7143,    4332,    2628,   1594,   967,    586,    356,    216,    131,
}};

/* tanh's slope on the Q16 grid, per cell of 1/16: (1 - y²) / 16, in Q16. */
static int16_t tanh_cell_slope(uint16_t y)
{
    return (int16_t)((65536u - (fx_umul16x16(y, y) >> 16)) >> 4);
}

/* A Q31 value in [0, 2^31] as a float: the conversion is exact to float32's rounding, and
 * the scale by 2^-31 is a change of exponent (the value is 0 or a normal number). */
static float q31_to_float(uint32_t v)
{
    float f = (float)v;
    uint32_t bits;
    memcpy(&bits, &f, sizeof bits);
    if (bits != 0u) {
        bits -= (uint32_t)31 << 23;
    }
    memcpy(&f, &bits, sizeof f);
    return f;
}

float tanh_f32(float x)
{
    uint32_t bits;
    memcpy(&bits, &x, sizeof bits);
    /* the biased exponent, bits 23-30, from whole bytes (the AVR loops on other shifts) */
    uint8_t e = (uint8_t)((uint8_t)(bits >> 24) << 1 | (uint8_t)((uint16_t)(bits >> 16) >> 7));
    uint32_t m = (bits & 0x7fffffu) | 0x800000u; /* |x| = m 2^(e - 150) */
    uint32_t y31;
    if (e < 107u || (e == 255u && (bits & 0x7fffffu) != 0u)) {
        return x; /* |x| < 2^-20: tanh x = x to float32's precision; NaN passes */
    }
    if (e <= 128u) { /* |x| < 4: cubic Hermite on the grid, slopes 1 - y² */
        uint8_t sh = (uint8_t)(131u - e); /* the position |x| 2^19 = m >> sh */
        if (sh >= 16u) {
            m >>= 16;
            sh = (uint8_t)(sh - 16u);
        }
        if (sh >= 8u) {
            m >>= 8;
            sh = (uint8_t)(sh - 8u);
        }
        m >>= sh;
        uint8_t k = (uint8_t)((uint8_t)(m >> 16) << 1 | (uint8_t)((uint16_t)m >> 15));
        uint16_t t = (uint16_t)m & 0x7fffu; /* Q15 */
        uint16_t y0 = rom_u16(ROM_AT(tanh_q16, k)), y1 = rom_u16(ROM_AT(tanh_q16, k + 1u));
        int16_t m0 = tanh_cell_slope(y0), m1 = tanh_cell_slope(y1);
        int16_t d = (int16_t)(y1 - y0);
        int16_t c2 = (int16_t)(3 * d - 2 * m0 - m1), c3 = (int16_t)(m0 + m1 - 2 * d);
        /* the 16 × 16 products inline (fixmath.h), where avr-gcc called its library's */
        uint16_t t2 = (uint16_t)((fx_umul16x16(t, t) << 1) >> 16); /* >> 15, by bytes */
        uint16_t t3 = (uint16_t)((fx_umul16x16(t2, t) << 1) >> 16);
        int32_t r = fx_smul16x16(m0, t) + fx_smul16x16(c2, t2) + fx_smul16x16(c3, t3); /* Q31 */
        y31 = ((uint32_t)y0 << 16 >> 1) + (uint32_t)r;
    } else if (e <= 130u) { /* 4 <= |x| < 16: the tail table, linear in quarters */
        uint32_t q = (m >> (140u - e)) - ((uint32_t)4 << 10); /* (|x| - 4) 2^10 */
        uint8_t k = (uint8_t)(q >> 8);
        if (k >= 20u) {
            y31 = (uint32_t)1 << 31;
        } else {
            uint32_t g0 = rom_u32(ROM_AT(tanh_tail_q32, k));
            uint32_t g = g0 - ((g0 - rom_u32(ROM_AT(tanh_tail_q32, k + 1u))) * (uint8_t)q >> 8);
            y31 = ((uint32_t)1 << 31) - (g >> 1);
        }
    } else {
        y31 = (uint32_t)1 << 31;
    }
    float y = q31_to_float(y31);
    return (bits & 0x80000000u) ? -y : y;
}

int32_t fx_from_float(float x, uint8_t q, uint8_t *status)
{
    if (!(x == x)) {
        *status |= STATUS_NOT_FINITE;
        return 0;
    }
    float scaled = x;
    for (uint8_t i = 0; i < q; i++) {
        scaled *= 2.0f; /* exact: a power of two */
    }
    if (scaled >= 2147483647.0f) {
        *status |= STATUS_SATURATED;
        return FX_MAX;
    }
    if (scaled <= -2147483648.0f) {
        *status |= STATUS_SATURATED;
        return FX_MIN;
    }
    return (int32_t)(scaled < 0.0f ? scaled - 0.5f : scaled + 0.5f);
}

void fx_small_cos_sin_q30(int32_t eps, int32_t *c, int32_t *s, uint8_t *status)
{
    const int32_t one = (int32_t)1 << 30;
    int32_t e2 = fx_mul(eps, 30, eps, 30, 30, status);
    int32_t e4 = fx_mul(e2, 30, e2, 30, 30, status);
    *c = fx_add(fx_sub(one, e2 / 2, status), e4 / 24, status);
    int32_t s3 = fx_sub(one, fx_sub(e2 / 6, e4 / 120, status), status);
    *s = fx_mul(eps, 30, s3, 30, 30, status);
}

/* The series to x^11, for |x| <= 1/2, as x + x c with c = x² p(x²) <= 0.046: x² and p's
 * Q16 coefficients through 16 x 16 products (c within 2e-5, so the result within 1e-5 rad
 * at x = 1/2 and 2e-7 at 0.1), and one 32 x 16 product for x c. */
static int32_t asin_series_q30(int32_t x, uint8_t *status)
{
    static const uint16_t c[] = {10923, 4915, 2926, 1991, 1466}; /* 1/6 ... 63/2816 */
    int16_t h = (int16_t)((uint32_t)x << 1 >> 16);               /* x >> 15: Q15, <= 2^14 */
    uint16_t x2 = (uint16_t)(((uint32_t)((int32_t)h * h) << 2) >> 16); /* Q16, within 2^-16 */
    uint8_t i = x2 < 1024u ? 2u : 4u; /* |x| < 1/8: the x^9 and x^11 terms add < 2e-8 rad */
    uint16_t p = c[i];
    while (i-- > 0u) {
        p = (uint16_t)(c[i] + (uint16_t)(((uint32_t)p * x2) >> 16));
    }
    int16_t corr = (int16_t)(((uint32_t)p * x2) >> 16);
    return fx_add(x, fx_mul16(x, corr, 16, status), status);
}

int32_t fx_asin_q30(int32_t x, uint8_t *status)
{
    const int32_t one = (int32_t)1 << 30, half = (int32_t)1 << 29;
    if (x > one || x < -one) {
        *status |= STATUS_CLAMPED;
        x = x > 0 ? one : -one;
    }
    if (x <= half && x >= -half) {
        return asin_series_q30(x, status);
    }
    /* asin x = π/2 - 2 asin sqrt((1 - x)/2) for x > 1/2, the root within the series'. */
    int32_t mag = x > 0 ? x : -x;
    int32_t r = fx_sqrt((one - mag) / 2, 30, status);
    int32_t a = 1686629713 /* π/2, Q30 */ - 2 * asin_series_q30(r, status);
    return x > 0 ? a : -a;
}

/* log2(1 + k/16) in Q24, k = 0..16 (not static: fx_log2_avr.S reads it too). */
const ROM ROM_TABLE(int32_t, 17) fx_log2_table = {{
    0,        1467383,  2850868,  4159533,  5401057,  6581994,  7707984,  8783912, 9814042,
    10802114, 11751428, 12664911, 13545168, 14394532, 15215099, 16008758, 16777216,
}};

int32_t fx_log2_q24_c(int32_t x, uint8_t q)
{
    if (x <= 0) {
        return INT32_MIN;
    }
    uint32_t m = (uint32_t)x;
    int8_t top = 31;
    while (!(m & 0xff000000u)) { /* whole bytes first: the AVR shifts one bit a cycle pair */
        m <<= 8;
        top -= 8;
    }
    while (!(m & 0x80000000u)) { /* the leading bit to bit 31: m = 2^31 (1 + f) */
        m <<= 1;
        top--;
    }
    /* f in 16ths (bits 30..27), the rest (26..17) from the top half: byte moves and a
     * few bit shifts, where a 32-bit shift by 27 or 17 is a loop on the AVR. */
    uint16_t h = (uint16_t)(m >> 16);
    uint8_t idx = (uint8_t)(h >> 11) & 15u;
    uint16_t frac = (uint16_t)(h << 5) & 0xffc0u; /* bits 10..1 of h, times 2^6 */
    int32_t lo = rom_i32(ROM_AT(fx_log2_table, idx)),
            hi = rom_i32(ROM_AT(fx_log2_table, idx + 1u));
    /* (hi - lo) frac 2^-16 rounded half up, hi - lo < 2^21 split at bit 16: two 16 × 16
     * products inline and a two-byte shift, where a 32 × 16 product was a call and the
     * shift by 10 a loop */
    uint32_t diff = (uint32_t)(hi - lo);
    uint32_t low = fx_umul16x16((uint16_t)diff, frac) + 0x8000u;
    uint32_t step = fx_umul16x16((uint16_t)(diff >> 16), frac) + (low >> 16);
    return (int32_t)((uint32_t)(uint8_t)(top - (int8_t)q) << 24) + lo + (int32_t)step;
}
