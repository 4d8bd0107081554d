#include "linalg/bfp24.h"

#include <math.h>
#include <string.h>

/* Both builds are little-endian (the AVR and the hosts the native board runs on): the
 * bytes of an int64 are read in memory, where the AVR calls a library routine for each
 * 64-bit shift. Everything else works a byte at a time, which the AVR does in one
 * instruction, where its 32-bit shifts by a count known only at run time loop a bit at
 * a time. */
typedef char bfp24_little_endian[__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__ ? 1 : -1];

static uint32_t bits_of(float x)
{
    uint32_t b;
    memcpy(&b, &x, sizeof b);
    return b;
}

/* The biased exponent, a subnormal's or a zero's read as 1 (a zero's mantissa is 0). */
static uint8_t exponent(uint32_t bits)
{
    uint8_t ex = (uint8_t)((uint8_t)((uint8_t)(bits >> 24) << 1) | ((uint8_t)(bits >> 16) >> 7));
    return ex != 0u ? ex : 1u;
}

int16_t bfp24_from_f32_c(const float *x, uint8_t n, uint32_t *m)
{
    uint8_t top = 1;
    for (uint8_t i = 0; i < n; i++) {
        uint8_t ex = exponent(bits_of(x[i]));
        if (ex == 0xFFu) {
            return BFP24_NOT_FINITE;
        }
        top = ex > top ? ex : top;
    }
    for (uint8_t i = 0; i < n; i++) {
        uint32_t b = bits_of(x[i]);
        uint8_t ex = exponent(b), down = (uint8_t)(top - ex);
        uint8_t m0 = (uint8_t)b, m1 = (uint8_t)(b >> 8), m2 = (uint8_t)(b >> 16);
        m2 = (uint8_t)((m2 & 0x7Fu) | ((b & 0x7F800000ul) != 0u ? 0x80u : 0u));
        uint32_t mag = 0;
        if (down < 24u) {
            if (down >= 16u) { /* by whole bytes, then bits */
                m0 = m2;
                m1 = m2 = 0;
            } else if (down >= 8u) {
                m0 = m1;
                m1 = m2;
                m2 = 0;
            }
            mag = ((uint32_t)m2 << 16 | (uint16_t)((uint16_t)m1 << 8 | m0)) >> (down & 7u);
        }
        m[i] = mag | (b & BFP24_SIGN);
    }
    return (int16_t)(top - 150);
}

uint8_t bfp24_from_i64_c(const int64_t *s, uint8_t n, uint32_t *m)
{
    uint64_t any = 0; /* the magnitudes' union: its top bit is the largest's */
    for (uint8_t i = 0; i < n; i++) {
        any |= s[i] < 0 ? (uint64_t)0 - (uint64_t)s[i] : (uint64_t)s[i];
    }
    uint8_t bits = 0;
    for (; any != 0u; any >>= 1) {
        bits++;
    }
    uint8_t k = bits > 24u ? (uint8_t)(bits - 24u) : 0u;
    for (uint8_t i = 0; i < n; i++) {
        uint64_t mag = s[i] < 0 ? (uint64_t)0 - (uint64_t)s[i] : (uint64_t)s[i];
        m[i] = (uint32_t)(mag >> k) | (s[i] < 0 ? BFP24_SIGN : 0u);
    }
    return k;
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

void bfp24_band_c(const uint32_t *r, const uint32_t *c, uint8_t rows, int64_t *out)
{
    for (uint8_t i = 0; i < rows; i++) {
        uint8_t left = (uint8_t)(rows - i);
        out[i] = bfp24_dot_c(r + 3u * i, c + i, left < 3u ? left : 3u);
    }
}

float bfp24_to_f32_c(int64_t s, int16_t e)
{
    /* the magnitude's bytes, least significant first, after four zero bytes */
    uint8_t by[12] = {0};
    memcpy(by + 4, &s, sizeof s);
    uint8_t sign = by[11] & 0x80u;
    if (sign != 0u) {
        uint8_t carry = 1;
        for (uint8_t i = 4; i < 12u; i++) {
            uint16_t v = (uint16_t)((uint8_t)~by[i] + carry);
            by[i] = (uint8_t)v;
            carry = (uint8_t)(v >> 8);
        }
    }
    uint8_t t = 11; /* the highest non-zero byte */
    while (by[t] == 0u) {
        if (--t < 4u) {
            return 0.0f;
        }
    }
    /* w: the four bytes from the top, then the next byte and a sticky for the rest */
    uint32_t w = (uint32_t)by[t] << 24 | (uint32_t)by[t - 1u] << 16 |
                 (uint16_t)((uint16_t)by[t - 2u] << 8 | by[t - 3u]);
    uint8_t below = by[t - 4u], sticky = 0;
    for (uint8_t i = 4; i + 4u < t; i++) {
        sticky |= by[i];
    }
    int16_t ex = (int16_t)(e + 8 * ((int16_t)t - 7)); /* value = (w + below 2^-8 + ...) 2^ex */
    while ((by[t] & 0x80u) == 0u) { /* at most 7 bits: the top byte is not zero */
        by[t] = (uint8_t)(by[t] << 1);
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
    uint8_t top = sign != 0u ? 0x80u : 0u, next = 0;
    if (biased >= 255) {
        top |= 0x7Fu;
        next = 0x80u;
        mant = 0;
    } else if (biased <= 0) {
        mant = 0;
    } else { /* by bytes: the AVR shifts 32 bits by 23 a bit at a time */
        top |= (uint8_t)((uint8_t)biased >> 1);
        next = (uint8_t)((uint8_t)((uint8_t)biased << 7) | ((uint8_t)(mant >> 16) & 0x7Fu));
    }
    uint32_t out = (uint32_t)((uint16_t)top << 8 | next) << 16 | (uint16_t)mant;
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
