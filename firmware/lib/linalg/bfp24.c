#include "linalg/bfp24.h"

#include <math.h>
#include <string.h>

static uint32_t bits_of(float x)
{
    uint32_t b;
    memcpy(&b, &x, sizeof b);
    return b;
}

/* The biased exponent a subnormal or a zero is read at (a zero's mantissa is 0). */
static uint8_t exponent(uint32_t bits)
{
    uint8_t ex = (uint8_t)(bits >> 23);
    return ex != 0u ? ex : 1u;
}

int16_t bfp24_from_f32(const float *x, uint8_t n, uint32_t *m)
{
    uint8_t top = 1;
    for (uint8_t i = 0; i < n; i++) {
        uint8_t ex = exponent(bits_of(x[i]) & 0x7FFFFFFFul);
        if (ex == 0xFFu) {
            return BFP24_NOT_FINITE;
        }
        top = ex > top ? ex : top;
    }
    for (uint8_t i = 0; i < n; i++) {
        uint32_t b = bits_of(x[i]);
        uint8_t down = (uint8_t)(top - exponent(b & 0x7FFFFFFFul));
        uint32_t mag = (b & 0x7FFFFFul) | ((b & 0x7F800000ul) != 0u ? 0x800000ul : 0u);
        /* by whole bytes, then bits: a shift by a count known only at run time loops a
         * bit at a time on the AVR */
        for (; down >= 8u && mag != 0u; down = (uint8_t)(down - 8u)) {
            mag >>= 8;
        }
        mag = down >= 8u ? 0u : mag >> down;
        m[i] = mag | (b & BFP24_SIGN);
    }
    return (int16_t)(top - 150);
}

int64_t bfp24_dot_c(const uint32_t *a, const uint32_t *b, uint8_t n)
{
    int64_t s = 0;
    for (uint8_t i = 0; i < n; i++) {
        int64_t p = (int64_t)(a[i] & 0xFFFFFFul) * (int64_t)(b[i] & 0xFFFFFFul);
        s += ((a[i] ^ b[i]) & BFP24_SIGN) != 0u ? -p : p;
    }
    return s;
}

float bfp24_to_f32(int64_t s, int16_t e)
{
    uint32_t sign = 0;
    uint64_t mag = (uint64_t)s;
    if (s < 0) {
        sign = BFP24_SIGN;
        mag = (uint64_t)0 - mag;
    }
    /* the magnitude's bytes, least significant first (both builds are little-endian;
     * on the AVR a 64-bit shift is a library call), by[0] a zero byte below them; t the
     * highest non-zero one */
    uint8_t by[9];
    by[0] = 0;
    memcpy(by + 1, &mag, sizeof mag);
    int8_t t = -1;
    for (uint8_t i = 1; i < 9u; i++) {
        t = by[i] != 0u ? (int8_t)i : t;
    }
    if (t < 0) {
        return 0.0f;
    }
    /* w: the four bytes from the top (zeros past the lowest), then the next byte and a
     * sticky for the rest */
    uint32_t w = 0;
    uint8_t below = 0, sticky = 0;
    for (int8_t i = t; i > t - 4; i--) {
        w = (w << 8) | (i >= 0 ? by[i] : 0u);
    }
    if (t >= 4) {
        below = by[t - 4];
        for (int8_t i = 0; i < t - 4; i++) {
            sticky |= by[i];
        }
    }
    int16_t ex = (int16_t)(e + 8 * (t - 4)); /* value = (w + below 2^-8 + ...) 2^ex */
    while ((w & 0x80000000ul) == 0u) { /* at most 7 bits: the top byte is not zero */
        w = (w << 1) | (below >> 7);
        below = (uint8_t)(below << 1);
        ex--;
    }
    /* 24 bits kept, w's low byte and below decide the rounding */
    uint32_t mant = w >> 8;
    uint8_t rest = (uint8_t)w;
    uint8_t more = (uint8_t)((rest & 0x7Fu) | below | sticky);
    if ((rest & 0x80u) != 0u && (more != 0u || (mant & 1u) != 0u)) {
        mant++;
        if (mant == 0x1000000ul) {
            mant >>= 1;
            ex++;
        }
    }
    int16_t biased = (int16_t)(ex + 8 + 150); /* mant in [2^23, 2^24) times 2^(ex + 8) */
    uint32_t out;
    if (biased >= 255) {
        out = sign | 0x7F800000ul;
    } else if (biased <= 0) {
        out = sign;
    } else {
        out = sign | ((uint32_t)biased << 23) | (mant & 0x7FFFFFul);
    }
    float f;
    memcpy(&f, &out, sizeof f);
    return f;
}

float bfp24_dot_f32(const uint32_t *a, int16_t ea, const uint32_t *b, int16_t eb, uint8_t n)
{
    if (ea == BFP24_NOT_FINITE || eb == BFP24_NOT_FINITE) {
        return NAN;
    }
    return bfp24_to_f32(bfp24_dot(a, b, n), (int16_t)(ea + eb));
}
