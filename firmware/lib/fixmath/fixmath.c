#include "fixmath/fixmath.h"

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
static const uint16_t tanh_table[65] = {
    0,     2045,  4075,  6073,  8025,  9919,  11743, 13486, 15143, 16706, 18173, 19542, 20813,
    21986, 23066, 24054, 24956, 25776, 26519, 27191, 27797, 28341, 28830, 29268, 29660, 30010,
    30322, 30600, 30847, 31067, 31262, 31435, 31589, 31726, 31846, 31953, 32048, 32132, 32206,
    32271, 32329, 32381, 32426, 32466, 32501, 32532, 32560, 32584, 32606, 32625, 32642, 32657,
    32670, 32681, 32691, 32700, 32708, 32715, 32721, 32727, 32732, 32736, 32740, 32743, 32746,
};

int32_t fx_tanh(int32_t x, uint8_t qx, uint8_t q_out)
{
    uint32_t mag = x < 0 ? (uint32_t)0 - (uint32_t)x : (uint32_t)x;
    uint8_t frac_bits = (uint8_t)(qx - 4u); /* the table's step is 1/16 */
    uint32_t idx = mag >> frac_bits;
    int32_t y;
    if (idx >= 64u) {
        y = tanh_table[64];
    } else {
        uint32_t frac = mag & (((uint32_t)1 << frac_bits) - 1u);
        /* Interpolate with 15 fractional bits of the position, so the product fits. */
        frac = frac_bits > 15u ? frac >> (frac_bits - 15u) : frac << (15u - frac_bits);
        int32_t lo = tanh_table[idx], hi = tanh_table[idx + 1u];
        y = lo + (int32_t)(((uint32_t)(hi - lo) * frac + (1u << 14)) >> 15);
    }
    y = (int32_t)((uint32_t)y << (q_out - 15u));
    return x < 0 ? -y : y;
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

/* The series, for |x| <= 1/2. */
static int32_t asin_series_q30(int32_t x, uint8_t *status)
{
    static const int32_t c[] = {1073741824, 178956971, 80530637, 47934905, 32622364};
    int32_t x2 = fx_mul_shr(x, x, 30, status);
    int32_t acc = c[4];
    for (int8_t i = 3; i >= 0; i--) {
        acc = fx_add(fx_mul_shr(acc, x2, 30, status), c[i], status);
    }
    return fx_mul_shr(acc, x, 30, status);
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

/* log2(1 + k/16) in Q24, k = 0..16. */
static const int32_t log2_table[17] = {
    0,        1467383,  2850868,  4159533,  5401057,  6581994,  7707984,  8783912, 9814042,
    10802114, 11751428, 12664911, 13545168, 14394532, 15215099, 16008758, 16777216,
};

int32_t fx_log2_q24(int32_t x, uint8_t q)
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
    uint32_t idx = (m >> 27) & 15u, frac = (m >> 17) & 0x3ffu; /* f in 16ths, the rest */
    int32_t lo = log2_table[idx], hi = log2_table[idx + 1u];
    int32_t mant = lo + (int32_t)(((uint32_t)(hi - lo) * frac + (1u << 9)) >> 10);
    return (int32_t)(top - (int8_t)q) * 16777216 + mant;
}
