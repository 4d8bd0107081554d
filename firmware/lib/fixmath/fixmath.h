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

#define FX_MAX INT32_MAX
#define FX_MIN INT32_MIN

/* x clamped to int32, flagging saturation. */
int32_t fx_sat(int64_t x, uint8_t *status);

int32_t fx_add(int32_t a, int32_t b, uint8_t *status);
int32_t fx_sub(int32_t a, int32_t b, uint8_t *status);
int32_t fx_neg(int32_t a, uint8_t *status);

/* x * 2^-shift rounded to nearest, ties away from zero; shift may be negative. */
int64_t fx_round_shift(int64_t x, int8_t shift);

/* a (qa) * b (qb) -> q_out. */
int32_t fx_mul(int32_t a, uint8_t qa, int32_t b, uint8_t qb, uint8_t q_out, uint8_t *status);

/* a · b · 2^-s (1 <= s <= 62), rounded half up, saturated: the fast kernel for hot
 * loops (no variable-width rounding logic; GCC, in both builds, shifts a negative int64
 * arithmetically). */
int32_t fx_mul_shr(int32_t a, int32_t b, uint8_t s, uint8_t *status);

/* a (qa) / b (qb) -> q_out; b == 0 saturates towards a's sign and flags STATUS_SINGULAR. */
int32_t fx_div(int32_t a, uint8_t qa, int32_t b, uint8_t qb, uint8_t q_out, uint8_t *status);

/* a from q_in to q_out. */
int32_t fx_rescale(int32_t a, uint8_t q_in, uint8_t q_out, uint8_t *status);

/* tanh(x) for x in qx (qx >= 4) -> q_out (15 <= q_out <= 30): a 65-entry Q15 table
 * over [0, 4] with linear interpolation; |error| <= 7e-4 for every x (3.8e-4 inside
 * [-4, 4], tanh(4)'s distance to 1 beyond). */
int32_t fx_tanh(int32_t x, uint8_t qx, uint8_t q_out);

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
 * and a 17-entry table with linear interpolation, |error| < 1e-3. */
int32_t fx_log2_q24(int32_t x, uint8_t q);

#endif
