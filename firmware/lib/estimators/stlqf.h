/* STLQF (seed 002, eqs. 11-27): m, C_dA_f and grade from an 11-sample window, each
 * parameter linear in local time, the error filtered by α, β, γ (eq. 16 corrected)
 * and weighted by A (Table 3), the estimate at the window centre (WL samples old).
 * G = Σ_k W_kᵀ A W_k is formed as Xᵀ X, X = R Φ̃, R the banded factor of the weight A
 * spreads over the nine filtered rows; the system is Jacobi-scaled and solved by
 * Cholesky with μ pulling each value towards the previous window's and each slope
 * towards zero; μ adapts between mu_min and mu to the mass's information in the last
 * window (host: estimators/stlqf.py). Both modes solve for the step from the prior
 * against the window's residual ζ - Φ̃ θ_prior, where m v̇ cancels most of ζ.
 *
 * FIXED computes each filtered row exactly in int64 and keeps it as int32 mantissas
 * with an exponent per input (block floating point), and solves for the step from
 * the prior: the window's residual against the last estimate is formed from the rows
 * (where m v̇ cancels most of ζ), then every column of X and the residual is an int16
 * with an exponent of its own (block floating point), so the Gram sums are exact
 * int16 products; the system is scaled by powers of two and solved by LDLᵀ in Q30
 * (linalg/ldl_q). Its inputs must keep longit's FIXED bounds, and χ2/T² < 2^20.
 *
 * Inputs  v [m/s] Q24, v̇ [m/s²] Q24, z [N] Q14.  Outputs m̂ [kg] Q16, Ĉ_dA_f [m²] Q16,
 * β̂_r [deg] Q20, log10 cond Q24.  Params  χ1, χ2, a11 a12 a13 a22 a23 a33, μ,
 * μ_min, held_max, jitter_max, τ_jitter, then longit's (ε, ρ, g, m0, C_dA_f0, T,
 * prefilter Hz). ILL_CONDITIONED: the prior's share of m̂, μ G_mm [(G + μ diag G)⁻¹]_mm,
 * is above held_max (the window's data do not determine the mass), or m̂'s mean step per
 * window over τ_jitter of time is above jitter_max kg (noise moves it). */
#ifndef VEHIL_ESTIMATORS_STLQF_H
#define VEHIL_ESTIMATORS_STLQF_H

#include <stdint.h>

#include "estimators/estimator.h"
#include "estimators/longit.h"

#define STLQF_ID 30u
#define STLQF_WL 5u
#define STLQF_ROWS (2u * STLQF_WL - 1u) /* filtered rows per window: φ̃[k] needs φ[k-2] */
#define STLQF_COLS 5u /* per row: ψ̃ and the time column's e for v̇ and ½ρv², then ζ */
#define STLQF_MASS 1u /* θ's entry of the mass at the window centre */
#define STLQF_LAST 5u /* the mass's unknown in the solve: last, so its pivot is its information */

typedef struct {
    float c1, c2; /* χ1/T, χ2/T² */
    float mu, mu_max, mu_min, held_max; /* μ: this window's, between mu_min and mu_max */
    float jitter, jitter_a, jitter_max;  /* m̂'s mean step (kg), its weight T / τ, the flag's */
    uint32_t band[STLQF_ROWS][3]; /* R(i, i + d) as a block (linalg/bfp24) */
    int16_t e_band;               /* its exponent */
    uint32_t x_g[2][STLQF_ROWS]; /* X's columns of g/cos ε (constant: its filters are exact) */
    int16_t e_g[2];              /* as blocks (linalg/bfp24), their exponents */
    float g_gg[3];               /* their Gram entries */
    float theta[6];            /* [slope, value at the centre] per parameter */
} stlqf_f32_t;

typedef struct {
    int32_t c1, c2;             /* χ1/T Q16, χ2/T² Q6 */
    int32_t mu, mu_max, mu_min, held_max; /* Q30 */
    int32_t jitter, jitter_max;           /* m̂'s mean step and the flag's bound, Q16 kg */
    int16_t jitter_a;                     /* its weight T / τ, Q15 */
    int16_t band[STLQF_ROWS][3]; /* R scaled to |R_ij| < 2^14 */
    int16_t x_g[2][STLQF_ROWS];  /* X's g/cos ε columns */
    int8_t e_g[2];               /* their exponents */
    int32_t g_gg[3];             /* their Gram sums */
    int32_t theta[6];            /* Q16 */
    longit_q_t shared;
} stlqf_q_t;

/* A filtered row in FIXED: mantissas and an exponent per input. */
typedef struct {
    int32_t m[STLQF_COLS]; /* mantissas, |m| < 2^27 */
    int8_t k[3]; /* m 2^k is the exact row at the inputs' Q + 6: v̇'s, ½ρv²'s, ζ's */
} stlqf_row_q_t;

typedef struct {
    longit_t model;
    union {
        stlqf_f32_t f32;
        stlqf_q_t q;
    } u;
    union {
        float f[2][3];
        int32_t q[2][3];
    } hist; /* v̇, ½ρv², z of the last two samples, newest first */
    union {
        float f[STLQF_ROWS][STLQF_COLS];
        stlqf_row_q_t q[STLQF_ROWS];
    } rows; /* a ring: the oldest at head once full */
    uint8_t mode, n_hist, n_rows, head;
    uint8_t solved; /* a window solved since the reset: m̂'s steps count from the second */
} stlqf_state_t;

/* The window's rows in int32, one exponent per input (the largest row's, into peak[3]):
 * out[c][j] is the ring's row j from head, mantissa c, times 2^(k - peak) rounded half up
 * (0 past 30 bits down). On the AVR in assembly (stlqf_align_avr.S); the C twin gives the
 * same bits. */
void stlqf_align_q_c(const stlqf_row_q_t *rows, uint8_t head, int8_t *peak,
                     int32_t (*out)[STLQF_ROWS]);
#if defined(__AVR__)
void stlqf_align_q(const stlqf_row_q_t *rows, uint8_t head, int8_t *peak,
                   int32_t (*out)[STLQF_ROWS]);
#else
#define stlqf_align_q stlqf_align_q_c
#endif

/* in[0..n) · 2^-k (rounded half up) as int32 with |out| <= 2^27 - 1, from int64 (the
 * window's exact rows); returns k (0 for zeros). On the AVR in assembly
 * (stlqf_norm64_avr.S); the C twin gives the same bits. */
int8_t stlqf_normalize64_c(const int64_t *in, int32_t *out, uint8_t n);
#if defined(__AVR__)
int8_t stlqf_normalize64(const int64_t *in, int32_t *out, uint8_t n);
#else
#define stlqf_normalize64 stlqf_normalize64_c
#endif

extern const ROM estimator_t stlqf_estimator;

#endif
