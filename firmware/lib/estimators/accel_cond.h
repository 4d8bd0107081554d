/* Seed 003's signal conditioning (the paper's band-pass and double integration; the
 * filter types and the post high-pass are ours): one accelerometer channel ->
 * 2nd-order Butterworth high-pass f_hp -> 2nd-order Butterworth low-pass f_lp ->
 * trapezoid -> first-order high-pass f_post -> trapezoid -> first-order high-pass f_post
 * -> displacement. Causal; designed in configure by the bilinear transform with
 * prewarping (tan by a continued fraction, so the AVR and the host agree bit for bit).
 * Params (3, in this order): f_hp Q24, f_lp Q24, f_post Q24 (0: no post high-pass).
 * The high-pass runs in delta form (its poles sit near z = 1, where direct form I loses
 * 0.35 % of the displacement to float32 rounding): with Δ = y1 - y2,
 *   Δ <- (1 - c2) Δ + g (x - 2 x1 + x2) - c12 y1,  y = y1 + Δ,
 * c2 = 1 - a2 = 2√2 K g, c12 = 1 + a1 + a2 = 4 K² g, g = 1/(1 + √2 K + K²).
 * Fixed point: raw data as it comes, Q16; high-passed and its step ACCEL_QH (Q21,
 * ±1,024 m/s²: over four times the -235 m/s² an unsprung mass reaches on hard bumps,
 * docs/estimators/eso.md), each carried with 16 bits below it (Q37, 48 bits): the
 * high-pass's poles sit within √2 K of z = 1, where a rounding to Q21 each step came out
 * of it 1/c12 times larger (4,000× at 5 ms, 10^5× at 1 ms); its two products are 32 × 24
 * and 32 × 32 products by c2 in Q24 and c12 in Q32, rounded to Q37. Low-passed times the
 * trapezoid's β = α T/2, the velocity's half-increment, Q26 (m/s); velocity Q26,
 * displacement Q28. Every other coefficient is a factor (fx_factor_t: 16 significant bits
 * at a shift chosen at CONFIG) that takes its operand's Q to its result's. */
#ifndef VEHIL_ESTIMATORS_ACCEL_COND_H
#define VEHIL_ESTIMATORS_ACCEL_COND_H

#include <stdint.h>

#include "estimators/params.h"
#include "fixmath/fixmath.h"

#define ACCEL_COND_N_PARAMS 3u
#define ACCEL_QH 21 /* Q format of the high-passed acceleration */

/* The Butterworth low-pass: numerator b0 (1, 2, 1), so b0 (x + 2 x1 + x2) is one product in
 * fixed point; float32 keeps b1 = 2 b0 (exact) and its three products' rounding. */
typedef struct {
    float b0, b1, a1, a2;
} biquad_f32_t;

typedef struct {
    fx_xfactor_t b0, p1, p2; /* Q19 sum -> Q26 (b0 g β); p1 = a1 + 2, p2 = 1 - a2: Q26 -> Q26 */
} biquad_q_t;

typedef struct {
    float g, c2, c12; /* the high-pass in delta form */
} hp_delta_f32_t;

typedef struct {
    uint32_t c2;  /* Q24 (below 1 at any corner), taking Q21 to Q37 by a 32 × 24 product */
    uint32_t c12; /* Q32 (CONFIG refuses f_hp T past 0.22, where c12 reaches 1): Q21 to Q37 */
} hp_delta_q_t; /* g is the low-pass's (docs/estimators/eso.md) */

typedef struct {
    hp_delta_f32_t hp;
    biquad_f32_t lp;
    float half_T, alpha, one_m_alpha;
} accel_cond_f32_t;

/* The trapezoid and the post high-pass as v <- v - γ v + β (l + l1): β = α T/2, γ = 1 - α;
 * fixed point folds the first β into the low-pass. */
typedef struct {
    hp_delta_q_t hp;
    biquad_q_t lp;
    fx_xfactor_t beta, gamma; /* β: Q26 -> Q28 (the first β is in the low-pass), γ: Q -> Q */
} accel_cond_q_t;

/* One channel's memory; the low-pass's input history is the high-pass's output history. */
typedef struct {
    float x1, x2, l1, l2; /* raw in, low-passed (the filtered acceleration) */
    float h1, h2, dh;     /* the high-pass's output, its history and last step */
    float v, x;           /* velocity and displacement */
} accel_chan_f32_t;

typedef struct {
    int32_t x1, x2;         /* Q16, the input as it came */
    int32_t l1, l2;         /* β times the low-passed acceleration, Q26 (m/s) */
    int32_t h1, h2, dh;     /* ACCEL_QH: the high-pass's output over g, its history, its step */
    int32_t v;              /* Q26 */
    int32_t x;              /* Q28 */
    uint16_t h1_lo, dh_lo;  /* h1's and dh's 16 bits below ACCEL_QH: with them, Q37 */
} accel_chan_q_t;

extern const ROM param_range_t accel_cond_ranges[ACCEL_COND_N_PARAMS];

/* The 2nd-order Butterworth low-pass at fc (Hz) for sample time T (s), fc T < 1/2. */
biquad_f32_t butter2_lp(float fc, float T);

void accel_cond_design_f32(accel_cond_f32_t *c, const uint8_t *params, uint8_t first,
                           uint8_t mode, float T);
/* 0, or 1 + the index of the parameter whose fixed-point form does not fit (f_hp: c12 >= 1). */
uint8_t accel_cond_q_from_f32(accel_cond_q_t *q, const accel_cond_f32_t *c, uint8_t *status);

/* One sample a (m/s²) in; the displacement out (ch->l1 is the filtered acceleration). */
float accel_cond_step_f32(const accel_cond_f32_t *c, accel_chan_f32_t *ch, float a);
/* a Q16 in, displacement Q28 out (ch->l1: β times the filtered acceleration, Q26). On the
 * AVR the ESO's front runs it in assembly (accel_cond_avr.S); this C twin gives the same bits
 * on the host. */
int32_t accel_cond_step_q_c(const accel_cond_q_t *c, accel_chan_q_t *ch, int32_t a,
                            uint8_t *status);

#endif
