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

int32_t fx_add(int32_t a, int32_t b, uint8_t *status) { return fx_sat((int64_t)a + b, status); }
int32_t fx_sub(int32_t a, int32_t b, uint8_t *status) { return fx_sat((int64_t)a - b, status); }
int32_t fx_neg(int32_t a, uint8_t *status) { return fx_sat(-(int64_t)a, status); }

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

int32_t fx_mul(int32_t a, uint8_t qa, int32_t b, uint8_t qb, uint8_t q_out, uint8_t *status)
{
    return fx_sat(fx_round_shift((int64_t)a * b, (int8_t)(qa + qb - q_out)), status);
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

int32_t fx_rescale(int32_t a, uint8_t q_in, uint8_t q_out, uint8_t *status)
{
    return fx_sat(fx_round_shift(a, (int8_t)(q_in - q_out)), status);
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
