/* Float32 vectors in block floating point with 24-bit mantissas, for dot products that are
 * exact in integers and rounded once (docs/estimators/stlqf.md, "Cost").
 *
 * A block holds x_i = ±m_i 2^e: one exponent e for the whole vector, each m_i < 2^24 as a
 * sign-magnitude word (bit 31 the sign, bits 0-23 the magnitude, the rest zero). The
 * largest |x_i| keeps its 24 bits exactly; a smaller one is truncated toward zero at
 * 2^e (so |error| < 2^e <= 2^-23 max |x|). Subnormals are read exactly; a vector with an
 * infinity or a NaN gets the exponent BFP24_NOT_FINITE, and every dot product with it is
 * a NaN. A dot product of two blocks is an exact int64 (bfp24_dot) times 2^(e_a + e_b),
 * rounded to nearest-even once (bfp24_to_f32). */
#ifndef VEHIL_LINALG_BFP24_H
#define VEHIL_LINALG_BFP24_H

#include <stdint.h>

#define BFP24_NOT_FINITE 0x4000 /* an exponent no finite vector has */
#define BFP24_SIGN 0x80000000ul

/* x[0..n) into m[0..n); returns e. On the AVR in assembly (bfp24_from_f32_avr.S, ~40
 * cycles a float and 5 a bit moved); the C twin gives the same bits. */
int16_t bfp24_from_f32_c(const float *x, uint8_t n, uint32_t *m);
#if defined(__AVR__)
int16_t bfp24_from_f32(const float *x, uint8_t n, uint32_t *m);
#else
#define bfp24_from_f32 bfp24_from_f32_c
#endif

/* Σ a_i b_i over n sign-magnitude words, exact: |sum| < n 2^48, so n <= 255 fits. On the
 * AVR an assembly loop of nine hardware MULs a pair (bfp24_dot_avr.S, ~76 cycles a pair);
 * the C twin gives the same bits. */
int64_t bfp24_dot_c(const uint32_t *a, const uint32_t *b, uint8_t n);
#if defined(__AVR__)
int64_t bfp24_dot(const uint32_t *a, const uint32_t *b, uint8_t n);
#else
#define bfp24_dot bfp24_dot_c
#endif

/* out[i] = Σ r[3 i + d] c[i + d] over d < min(3, rows - i), exact: a banded matrix (three
 * words a row, the last two rows' extra words unread) times a block. On the AVR
 * bfp24_dot's loop row by row within one call (bfp24_dot_avr.S); the C twin gives the same
 * bits. */
void bfp24_band_c(const uint32_t *r, const uint32_t *c, uint8_t rows, int64_t *out);
#if defined(__AVR__)
void bfp24_band(const uint32_t *r, const uint32_t *c, uint8_t rows, int64_t *out);
#else
#define bfp24_band bfp24_band_c
#endif

/* s 2^e rounded to nearest-even float32 (|e| < 2^14): ±inf past FLT_MAX, ±0 below
 * FLT_MIN (no subnormal results). On the AVR in assembly (bfp24_to_f32_avr.S, ~60-110
 * cycles, where the C takes ~430); the C twin gives the same bits. */
float bfp24_to_f32_c(int64_t s, int16_t e);
#if defined(__AVR__)
float bfp24_to_f32(int64_t s, int16_t e);
#else
#define bfp24_to_f32 bfp24_to_f32_c
#endif

/* Exact sums s[0..n) (|s| < 2^63) into a block m[0..n) at a power of two 2^k: the largest
 * keeps 24 bits, each truncated toward zero; returns k >= 0. On the AVR in assembly
 * (bfp24_from_i64_avr.S, ~110 cycles a sum); the C twin gives the same bits. */
uint8_t bfp24_from_i64_c(const int64_t *s, uint8_t n, uint32_t *m);
#if defined(__AVR__)
uint8_t bfp24_from_i64(const int64_t *s, uint8_t n, uint32_t *m);
#else
#define bfp24_from_i64 bfp24_from_i64_c
#endif

/* Σ a_i b_i of two blocks (exponents ea, eb) rounded once: NaN if either is not finite. */
float bfp24_dot_f32(const uint32_t *a, int16_t ea, const uint32_t *b, int16_t eb, uint8_t n);

#endif
