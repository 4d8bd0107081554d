#include "estimators/stlqf.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "fixmath/fixmath.h"
#include "linalg/bfp24.h"
#include "linalg/chol_f32.h"
#include "linalg/chol_q15.h"
#include "proto/wire.h"

enum {
    P_CHI1, P_CHI2, P_A11, P_A12, P_A13, P_A22, P_A23, P_A33,
    P_MU, P_MU_MIN, P_HELD, P_JITTER, P_TAU_JITTER, N_OWN
};
#define N_PARAMS (N_OWN + LONGIT_N_PARAMS)
#define CENTRE (STLQF_ROWS - 1u - STLQF_WL) /* row of the window centre */

static const ROM param_range_t ranges[N_OWN] = {
    {0.0f, 10.0f, 24},     {0.0f, 10.0f, 24},     {-100.0f, 100.0f, 24},
    {-100.0f, 100.0f, 24}, {-100.0f, 100.0f, 24}, {-100.0f, 100.0f, 24}, {-100.0f, 100.0f, 24},
    {-100.0f, 100.0f, 24}, {0.0f, 1.0f, 30},      {0.0f, 1.0f, 30},      {0.0f, 1.0f, 30},
    {0.0f, 1e4f, 16},      {1e-3f, 100.0f, 16},
};

/* Where the window's row j (oldest first) is in the ring. */
static uint8_t slot(const stlqf_state_t *s, uint8_t j)
{
    uint8_t i = (uint8_t)(s->head + j);
    return i >= STLQF_ROWS ? (uint8_t)(i - STLQF_ROWS) : i;
}

/* θ's entry of the solve's unknown i: the mass's value last (STLQF_LAST), so its
 * Cholesky pivot is its information given the rest (docs/estimators/stlqf.md). */
static uint8_t unknown(uint8_t i)
{
    return i == 0u ? 0u : i < STLQF_LAST ? (uint8_t)(i + 1u) : STLQF_MASS;
}

/* unknown(3) and unknown(4) are θ's 4 and 5, g/cos ε's (solve_q reads their constant
 * Gram entries by the solve's order) */
typedef char stlqf_g_prime_is_unknowns_3_4[STLQF_MASS == 1u && STLQF_LAST == 5u ? 1 : -1];

/* Time of row j from the window centre, in samples. */
static int8_t tau(uint8_t j) { return (int8_t)((int8_t)j - (int8_t)CENTRE); }

/* R (Q20) upper with bandwidth 2 and Rᵀ R = Σ_k E_kᵀ A E_k (A in Q24), the seven terms
 * k stacking rows k, k-1, k-2. In integers, so both modes and both builds get the same
 * R. Returns 0 when that weight is not positive definite (A is not). */
static uint8_t band_factor(int32_t band[STLQF_ROWS][3], const int32_t a[3][3])
{
    uint8_t st = 0; /* |a_ij| <= 100: nothing here leaves Q20's range */
    int32_t m[STLQF_ROWS][3] = {{0}};
    for (uint8_t k = 2; k < STLQF_ROWS; k++) {
        const uint8_t idx[3] = {k, (uint8_t)(k - 1u), (uint8_t)(k - 2u)};
        for (uint8_t p = 0; p < 3u; p++) {
            for (uint8_t q = 0; q < 3u; q++) {
                if (idx[q] >= idx[p]) {
                    m[idx[p]][idx[q] - idx[p]] += fx_rescale(a[p][q], 24, 20, &st);
                }
            }
        }
    }
    for (uint8_t i = 0; i < STLQF_ROWS; i++) {
        for (uint8_t d = 0; d < 3u; d++) {
            uint8_t j = (uint8_t)(i + d);
            if (j >= STLQF_ROWS) {
                band[i][d] = 0;
                continue;
            }
            int32_t s = m[i][d];
            for (uint8_t k = j >= 2u ? (uint8_t)(j - 2u) : 0u; k < i; k++) {
                s -= fx_mul(band[k][i - k], 20, band[k][j - k], 20, 20, &st);
            }
            if (d == 0u) {
                if (s <= 0) {
                    return 0;
                }
                band[i][0] = fx_sqrt(s, 20, &st);
            } else {
                band[i][d] = fx_div(s, 20, band[i][0], 20, 20, &st);
            }
        }
    }
    return 1;
}

/* ---- float32 ---- */

/* X = R col as a block (linalg/bfp24): col as a block, each row's three products by R
 * summed exactly in integers, the rows truncated to 24 bits at the largest. Returns X's
 * exponent. */
static int16_t weigh_f32(const stlqf_f32_t *f, const float *col, uint32_t *x)
{
    uint32_t c[STLQF_ROWS];
    int64_t wide[STLQF_ROWS];
    int16_t e = bfp24_from_f32(col, STLQF_ROWS, c);
    if (e == BFP24_NOT_FINITE) {
        return e; /* every dot product with x is a NaN */
    }
    bfp24_band(&f->band[0][0], c, STLQF_ROWS, wide);
    return (int16_t)(e + f->e_band + bfp24_from_i64(wide, STLQF_ROWS, x));
}

static void configure_f32(stlqf_f32_t *f, const longit_t *model, const uint8_t *params,
                          const int32_t band[STLQF_ROWS][3])
{
    float r[STLQF_ROWS][3];
    for (uint8_t i = 0; i < STLQF_ROWS; i++) {
        for (uint8_t d = 0; d < 3u; d++) {
            r[i][d] = (float)band[i][d] * (1.0f / 1048576.0f); /* Q20 */
        }
    }
    f->e_band = bfp24_from_f32(&r[0][0], STLQF_ROWS * 3u, &f->band[0][0]);
    float T = model->T;
    f->c1 = get_f32(params + 4u * P_CHI1) / T;
    f->c2 = get_f32(params + 4u * P_CHI2) / (T * T);
    f->mu_max = get_f32(params + 4u * P_MU);
    f->mu_min = get_f32(params + 4u * P_MU_MIN);
    f->held_max = get_f32(params + 4u * P_HELD);
    f->jitter_max = get_f32(params + 4u * P_JITTER);
    f->jitter_a = fminf(T / get_f32(params + 4u * P_TAU_JITTER), 1.0f);
    /* g/cos ε is constant, so its filtered columns are exact: τ g' + χ1 g'/T and g'. */
    float col[2][STLQF_ROWS];
    for (uint8_t j = 0; j < STLQF_ROWS; j++) {
        col[0][j] = ((float)tau(j) + f->c1) * model->g_cos;
        col[1][j] = model->g_cos;
    }
    for (uint8_t c = 0; c < 2u; c++) {
        f->e_g[c] = weigh_f32(f, col[c], f->x_g[c]);
    }
    for (uint8_t k = 0; k < 3u; k++) { /* (4, 4), (5, 4), (5, 5) */
        uint8_t a = k == 0u ? 0u : 1u, b = k == 2u ? 1u : 0u;
        f->g_gg[k] = bfp24_dot_f32(f->x_g[a], f->e_g[a], f->x_g[b], f->e_g[b], STLQF_ROWS);
    }
}

/* One sample's filtered row: x + χ1 Δx/T + χ2 Δ²x/T² as differences (α x + β x₋₁ + γ x₋₂
 * with α ~ 1e4 would cancel float32's digits away), and the time column's extra term
 * χ1 x₋₁/T + 2χ2 (x₋₁ - x₋₂)/T². */
static void filter_f32(const stlqf_f32_t *f, const float *x, const float h[2][3], float *row)
{
    for (uint8_t c = 0; c < 3u; c++) {
        float d1 = x[c] - h[0][c];
        float d0 = h[0][c] - h[1][c];
        float filtered = x[c] + f->c1 * d1 + f->c2 * (d1 - d0);
        if (c < 2u) {
            row[c] = filtered;
            row[2u + c] = f->c1 * h[0][c] + 2.0f * f->c2 * d0;
        } else {
            row[4] = filtered;
        }
    }
}

/* The window's θ: G = Xᵀ X and U = Xᵀ R ζ, Jacobi-scaled, (G_s + μ I) y = U_s + μ y_prior.
 * X's columns are blocks with 24-bit mantissas (linalg/bfp24), so each Gram sum is exact
 * in integers and rounded once: ~76 cycles a product on the AVR, where avr-libc's fmaf
 * took ~220 (docs/estimators/stlqf.md, "Cost"). */
static uint8_t solve_f32(stlqf_state_t *s, float *log_cond)
{
    stlqf_f32_t *f = &s->u.f32;
    /* The prior: each value where the last window's line puts it one sample later, each
     * slope zero. */
    float prior[6];
    for (uint8_t a = 0; a < 6u; a++) {
        prior[a] = (a & 1u) ? f->theta[a] + f->theta[a - 1u] : 0.0f;
    }
    /* Φ̃'s varying columns [τ v̇, v̇, τ q, q] and the residual against the prior,
     * ζ - Φ̃ θ_prior (where m v̇ cancels most of ζ, so its rounding is the residual's, not
     * ζ's), then X = R Φ̃ column by column. */
    float phi[5][STLQF_ROWS];
    float g_term = prior[5] * s->model.g_cos;
    for (uint8_t j = 0; j < STLQF_ROWS; j++) {
        const float *row = s->rows.f[slot(s, j)];
        phi[0][j] = (float)tau(j) * row[0] + row[2];
        phi[1][j] = row[0];
        phi[2][j] = (float)tau(j) * row[1] + row[3];
        phi[3][j] = row[1];
        phi[4][j] = fmaf(-prior[3], row[1], fmaf(-prior[1], row[0], row[4] - g_term));
    }
    uint32_t m[5][STLQF_ROWS];
    int16_t e[6 + 1];
    for (uint8_t c = 0; c < 5u; c++) {
        e[c < 4u ? c : 6u] = weigh_f32(f, phi[c], m[c]);
    }
    e[4] = f->e_g[0];
    e[5] = f->e_g[1];
    const uint32_t *col[6] = {m[0], m[1], m[2], m[3], f->x_g[0], f->x_g[1]}; /* θ's */
    float g[36], rhs[6];
    for (uint8_t i = 0; i < 6u; i++) {
        uint8_t a = unknown(i);
        for (uint8_t j = 0; j <= i; j++) {
            uint8_t b = unknown(j);
            /* g/cos ε's own entries are constant: (4, 4), (5, 4), (5, 5) */
            g[i * 6u + j] = a >= 4u && b >= 4u
                                ? f->g_gg[a + b - 8u]
                                : bfp24_dot_f32(col[a], e[a], col[b], e[b], STLQF_ROWS);
        }
        rhs[i] = bfp24_dot_f32(col[a], e[a], m[4], e[6], STLQF_ROWS);
    }
    /* (D G D + μ I) y = D U + μ y_prior with D = diag(G)^-1/2 and θ = D y is, multiplied
     * out, (G + μ diag G) θ = U + μ diag(G) θ_prior: the Jacobi-scaled system without
     * the scaling (Cholesky's rounding does not depend on it), ~12 k cycles saved; for
     * the step δ = θ - θ_prior, (G + μ diag G) δ = U - G θ_prior = Xᵀ R (ζ - Φ̃ θ_prior). */
    float scale[6];
    for (uint8_t i = 0; i < 6u; i++) {
        float gii = g[i * 6u + i];
        scale[i] = gii > 0.0f ? gii : 1.0f; /* a column of zeros (standing still) */
        g[i * 6u + i] += f->mu * scale[i];
    }
    float inv_d[6];
    if (!chol_ldl_solve_f32(g, rhs, 6, inv_d)) {
        *log_cond = INFINITY;
        return STATUS_SINGULAR;
    }
    /* The condition estimate of the scaled matrix: its pivots are D_i / G_ii, compared
     * as their reciprocals (products, no division each). */
    float lo = 0.0f, hi = 0.0f;
    for (uint8_t i = 0; i < 6u; i++) {
        float inv_pivot = inv_d[i] * scale[i];
        lo = (i == 0u || inv_pivot < lo) ? inv_pivot : lo;
        hi = (i == 0u || inv_pivot > hi) ? inv_pivot : hi;
        f->theta[unknown(i)] = prior[unknown(i)] + rhs[i];
    }
    *log_cond = log10f(hi / lo);
    /* The mass's scaled pivot D / G_mm is its information plus μ; the prior's share of
     * m̂ is μ over it (docs/estimators/stlqf.md). */
    float pivot = g[STLQF_LAST * 7u] / scale[STLQF_LAST];
    float held = f->mu / pivot;
    /* The next window's μ: mu_max (mu_max / ι)² within [mu_min, mu_max]. */
    float info = pivot - f->mu;
    if (f->mu_min < f->mu_max && info > f->mu_max) {
        float ratio = f->mu_max / info;
        float next = f->mu_max * ratio * ratio;
        f->mu = next > f->mu_min ? next : f->mu_min;
    } else {
        f->mu = f->mu_max;
    }
    return held > f->held_max ? STATUS_ILL_CONDITIONED : 0u;
}

/* ---- fixed point ---- */

#define ROW_LIMIT (((int32_t)1 << 27) - 1) /* |rows| in int32: τ ψ̃ + e still fits */
#define COL_LIMIT 16383 /* |column of Φ̃| as int16: three R products fit int32 */
#define X_LIMIT 15000   /* |column of X| as int16: nine squares fit int32 */
/* The rows' fraction bits: the inputs' (longit: v̇ Q24, ½ρv² Q18, z Q14) and 6 more. */
static const uint8_t row_q[3] = {24 + 6, 18 + 6, 14 + 6};
#define THETA_Q 16 /* θ's entries in FIXED */
#define DELTA_Q 24 /* the step from the prior, in the solve's units */


/* The time column τ ψ̃ + e down the window, τ = j - CENTRE, each product by its constant
 * τ in shifts and adds (an int32 product is a library call on the AVR). */
typedef char stlqf_time_column_is_written_out[STLQF_ROWS == 9u && CENTRE == 3u ? 1 : -1];

static void time_column(const int32_t *psi, const int32_t *e, int32_t *col)
{
    col[0] = e[0] - (2 * psi[0] + psi[0]);
    col[1] = e[1] - 2 * psi[1];
    col[2] = e[2] - psi[2];
    col[3] = e[3];
    col[4] = e[4] + psi[4];
    col[5] = e[5] + 2 * psi[5];
    col[6] = e[6] + (2 * psi[6] + psi[6]);
    col[7] = e[7] + 4 * psi[7];
    col[8] = e[8] + (4 * psi[8] + psi[8]);
}

/* x · 2^up, rounded (ties away from zero), saturated, in int32 (the AVR shifts an int64
 * by a library call and multiplies it by a power of two with a full 64-bit product), but
 * for a shift down past 30 bits. */
static int32_t scale_pow2(int32_t x, int16_t up, uint8_t *st)
{
    if (up < -30) {
        return up < -62 ? 0 : fx_sat(fx_round_shift(x, (int8_t)-up), st);
    }
    if (up < 0) { /* fx_round_shift's rounding in 32 bits: |x| + 2^29 < 2^32 */
        uint8_t down = (uint8_t)-up;
        uint32_t m = fx_shr32((x < 0 ? (uint32_t)0 - (uint32_t)x : (uint32_t)x) +
                                  fx_shl32(1u, (uint8_t)(down - 1u)),
                              down);
        return x < 0 ? -(int32_t)m : (int32_t)m;
    }
    int32_t v = fx_sat(x, st);
    if (up > 30 || v > (INT32_MAX >> up) || v < (INT32_MIN >> up)) {
        return v == 0 ? 0 : fx_sat(v > 0 ? INT64_MAX : INT64_MIN, st);
    }
    return v * ((int32_t)1 << up);
}

/* v 2^-down, rounded half up, by whole bytes and then bits (|v| < 2^30): floor((v +
 * 2^(down-1)) 2^-down) is (floor(v 2^(1-down)) + 1) >> 1, so no 2^(down-1) to form (a
 * shift by a count known only at run time loops a bit at a time on the AVR). */
static inline __attribute__((always_inline)) int32_t shift_down(int32_t v, uint8_t down)
{
    if (down == 0u) {
        return v;
    }
    if (down > 30u) {
        return 0;
    }
    for (down--; down >= 8u; down -= 8u) {
        v >>= 8;
    }
    return ((v >> down) + 1) >> 1;
}

void stlqf_align_q_c(const stlqf_row_q_t *rows, uint8_t head, int8_t *peak,
                     int32_t (*out)[STLQF_ROWS])
{
    peak[0] = peak[1] = peak[2] = INT8_MIN;
    for (uint8_t j = 0; j < STLQF_ROWS; j++) {
        for (uint8_t ch = 0; ch < 3u; ch++) {
            peak[ch] = rows[j].k[ch] > peak[ch] ? rows[j].k[ch] : peak[ch];
        }
    }
    uint8_t at = head;
    for (uint8_t j = 0; j < STLQF_ROWS; j++) {
        const int32_t *m = rows[at].m;
        const int8_t *k = rows[at].k;
        uint8_t down = (uint8_t)(peak[0] - k[0]);
        out[0][j] = shift_down(m[0], down);
        out[2][j] = shift_down(m[2], down);
        down = (uint8_t)(peak[1] - k[1]);
        out[1][j] = shift_down(m[1], down);
        out[3][j] = shift_down(m[3], down);
        out[4][j] = shift_down(m[4], (uint8_t)(peak[2] - k[2]));
        at = at == STLQF_ROWS - 1u ? 0u : (uint8_t)(at + 1u);
    }
}

#if defined(__AVR__)
/* stlqf_align_avr.S reads the rows at these offsets */
FX_ASM_LAYOUT(stlqf_row, sizeof(stlqf_row_q_t) == 23u && offsetof(stlqf_row_q_t, k) == 20u &&
                              STLQF_ROWS == 9u && STLQF_COLS == 5u);
#endif

/* The top half of v: by byte moves on the AVR, little-endian (avr-gcc calls a library
 * routine for a 64-bit shift, even by a constant). */
static uint32_t high_word(uint64_t v)
{
#if defined(__AVR__)
    uint32_t h;
    memcpy(&h, (const uint8_t *)&v + 4, sizeof h);
    return h;
#else
    return (uint32_t)(v >> 32);
#endif
}

/* |x|, its sign read from the top word (avr-gcc compares an int64 by a library call) */
static uint64_t magnitude(int64_t x)
{
    return (int32_t)high_word((uint64_t)x) < 0 ? (uint64_t)0 - (uint64_t)x : (uint64_t)x;
}

/* x 2^-k rounded half up (1 <= k <= 62) for a result below 2^28: one 64-bit shift to the
 * rounding bit (a library call on the AVR), the rest in int32. GCC (both builds) shifts
 * a negative int64 arithmetically. */
static int32_t round_down64(int64_t x, uint8_t k)
{
    int32_t y = (int32_t)(x >> (k - 1u));
    return (y >> 1) + (y & 1);
}

/* The columns go to int16 by fixmath's fx_norm16 (in assembly on the AVR), whose limits
 * are 14-bit. */
typedef char stlqf_limits_are_14_bits[(COL_LIMIT >> 13) == 1 && (X_LIMIT >> 13) == 1 ? 1 : -1];

int8_t stlqf_normalize64_c(const int64_t *in, int32_t *out, uint8_t n)
{
    uint64_t peak = 0; /* the magnitudes' OR: the largest one's bit length, no comparisons */
    for (uint8_t i = 0; i < n; i++) {
        peak |= magnitude(in[i]);
    }
    uint32_t top = high_word(peak);
    int8_t k = peak == 0u ? 0
                          : (int8_t)((top != 0u ? (uint8_t)(32u + longit_bit_length(top))
                                                : longit_bit_length((uint32_t)peak)) -
                                     27);
    if (k <= 0) { /* |in| < 2^27 */
        for (uint8_t i = 0; i < n; i++) {
            out[i] = (int32_t)((uint32_t)(int32_t)in[i] << -k);
        }
        return k;
    }
    for (;;) { /* one bit more where rounding up reached 2^27 */
        uint32_t big = 0;
        for (uint8_t i = 0; i < n; i++) {
            out[i] = round_down64(in[i], (uint8_t)k);
            uint32_t mag = out[i] < 0 ? (uint32_t)0 - (uint32_t)out[i] : (uint32_t)out[i];
            big = mag > big ? mag : big;
        }
        if (big <= (uint32_t)ROW_LIMIT) {
            return k;
        }
        k++;
    }
}

/* x = R col as int16 (X_LIMIT); returns x's exponent relative to col's (R at its own
 * scale, the same for every column, which cancels in the solve). */
static int8_t weigh(const int16_t band[STLQF_ROWS][3], const int32_t *col, int16_t *x)
{
    int16_t c[STLQF_ROWS];
    int32_t wide[STLQF_ROWS];
    int8_t e = fx_norm16(col, c, STLQF_ROWS, COL_LIMIT);
    /* R's band: three entries, fewer at the end (|R|, |c| <= COL_LIMIT: sums below 2^30) */
    fx_band16(band, c, wide, STLQF_ROWS);
    return (int8_t)(e + fx_norm16(wide, x, STLQF_ROWS, X_LIMIT));
}

/* nine products of at most X_LIMIT² fit int32 */
static int32_t dot_q(const int16_t *a, const int16_t *b) { return fx_dot16(a, b, STLQF_ROWS); }

static uint8_t configure_q(stlqf_q_t *q, const uint8_t *params, const int32_t band[STLQF_ROWS][3])
{
    uint8_t st = 0; /* the ranges checked keep every operation below in range */
    longit_configure_q(&q->shared, params, N_OWN);
    int32_t T = param_q(params, N_OWN + LONGIT_T);
    q->c1 = fx_div(param_q(params, P_CHI1), 24, T, 30, 16, &st);
    q->c2 = fx_div(fx_div(param_q(params, P_CHI2), 24, T, 30, 16, &st), 16, T, 30, 6, &st);
    if (q->c2 >= ((int32_t)1 << 26)) {
        return 1u + P_CHI2; /* χ2/T² past 2^20: the filter's products would not fit */
    }
    q->mu_max = param_q(params, P_MU);
    q->mu_min = param_q(params, P_MU_MIN);
    q->held_max = param_q(params, P_HELD);
    q->jitter_max = param_q(params, P_JITTER);
    int32_t a = fx_div(T, 30, param_q(params, P_TAU_JITTER), 16, 15, &st); /* T / τ, Q15 */
    q->jitter_a = (int16_t)(a < INT16_MAX ? a : INT16_MAX);
    int16_t flat[STLQF_ROWS * 3];
    fx_norm16(&band[0][0], flat, STLQF_ROWS * 3u, COL_LIMIT);
    memcpy(q->band, flat, sizeof flat);
    /* g/cos ε's filtered columns, exact: (τ + χ1/T) g' and g', in Q42. */
    int64_t col[2][STLQF_ROWS];
    int32_t narrow[STLQF_ROWS];
    for (uint8_t j = 0; j < STLQF_ROWS; j++) {
        col[0][j] = ((int64_t)tau(j) * 65536 + q->c1) * q->shared.g_cos;
        col[1][j] = (int64_t)q->shared.g_cos * 65536;
    }
    for (uint8_t c = 0; c < 2u; c++) {
        int8_t k = stlqf_normalize64(col[c], narrow, STLQF_ROWS);
        q->e_g[c] = (int8_t)(k + weigh(q->band, narrow, q->x_g[c]) - 42);
    }
    q->g_gg[0] = dot_q(q->x_g[0], q->x_g[0]);
    q->g_gg[1] = dot_q(q->x_g[1], q->x_g[0]);
    q->g_gg[2] = dot_q(q->x_g[1], q->x_g[1]);
    return 0;
}

/* filter_f32 in integers, exact but for χ1/T's product (rounded at 6 fraction bits
 * past the input's): the inputs' bounds and χ2/T² < 2^20 keep every sum in int64.
 * Stored as mantissas with an exponent per input, so a window's columns are aligned
 * in int32 (the AVR handles int64 a call at a time). */
static void filter_q(const stlqf_q_t *q, const int32_t *x, const int32_t h[2][3],
                     int32_t *m, int8_t *k)
{
    int64_t row[STLQF_COLS];
    for (uint8_t c = 0; c < 3u; c++) {
        int32_t d1 = x[c] - h[0][c], d0 = h[0][c] - h[1][c]; /* |x| < 2^30 keeps these */
        int64_t c2_d0 = fx_mul64(q->c2, d0);
        int64_t f = fx_mul64(x[c], 64) + fx_mul64_rs10(q->c1, d1) +
                    (fx_mul64(q->c2, d1) - c2_d0);
        if (c < 2u) {
            row[c] = f;
            row[2u + c] = fx_mul64_rs10(q->c1, h[0][c]) + (c2_d0 + c2_d0);
        } else {
            row[4] = f;
        }
    }
    for (uint8_t c = 0; c < 2u; c++) {
        const int64_t pair[2] = {row[c], row[2u + c]};
        int32_t out[2];
        k[c] = stlqf_normalize64(pair, out, 2);
        m[c] = out[0];
        m[2u + c] = out[1];
    }
    k[2] = stlqf_normalize64(&row[4], &m[4], 1);
}

/* a b 2^-n rounded half up, for a product that fits int32 at that scale: a kernel for
 * n >= 1, the exact int32 product shifted up otherwise. */
static int32_t product(int32_t a, int32_t b, int8_t n, uint8_t *st)
{
    if (n >= 1) {
        return n > 62 ? 0 : fx_mul_shr_n(a, b, st, (uint8_t)n);
    }
    return (int32_t)((uint32_t)(a * b) << -n);
}

/* The window's residual against the prior, ζ - Φ̃ θ_prior (the slopes' prior is 0, so
 * the v̇, ½ρv² and g' columns), from the rows in int32 (r, 2^e_r each channel) into
 * out at the exponent it returns: ζ's own, or coarser where a term would pass 2^28. Each
 * product is rounded once at that exponent by a fixed-shift kernel; four terms below
 * 2^28 keep the sum in int32. */
static int8_t residual(const stlqf_q_t *q, const int32_t *const r[3], const int8_t *e_r,
                       const int32_t *prior, int32_t *out)
{
    /* a term's operands: the row (|r| < 2^27) or g' (Q26, < 2^30), θ (Q16) */
    int8_t e_term[3], S = e_r[2];
    for (uint8_t c = 0; c < 3u; c++) {
        e_term[c] = (int8_t)(c < 2u ? e_r[c] - THETA_Q : -26 - THETA_Q);
        int32_t p = prior[2u * c + 1u];
        int8_t need = (int8_t)(longit_bit_length(p < 0 ? (uint32_t)0 - (uint32_t)p : (uint32_t)p) +
                               (c < 2u ? 27 : 30) + e_term[c] - 28);
        S = need > S ? need : S;
    }
    uint8_t st = 0; /* S keeps every term below 2^28: nothing saturates */
    int32_t g_term = product(prior[5], q->shared.g_cos, (int8_t)(S - e_term[2]), &st);
    for (uint8_t j = 0; j < STLQF_ROWS; j++) {
        out[j] = shift_down(r[2][j], (uint8_t)(S - e_r[2])) - g_term;
    }
    for (uint8_t c = 0; c < 2u; c++) { /* the products rounded by a kernel, one call a column */
        int8_t n = (int8_t)(S - e_term[c]);
        if (n >= 1) {
            fx_mul_shr_n_sub(prior[2u * c + 1u], &st, r[c], out, STLQF_ROWS, (uint8_t)n);
            continue;
        }
        for (uint8_t j = 0; j < STLQF_ROWS; j++) {
            out[j] -= product(prior[2u * c + 1u], r[c][j], n, &st);
        }
    }
    return S;
}

/* solve_f32's system for the step δ from the prior, with X's columns and the residual
 * in block floating point, x_a 2^E_a: (Gi + μ diag Gi) y = Ui in y_a = δθ_a 2^(E_a -
 * E_res), Gi, Ui the int Gram sums, as Gi / 2^32 in Q30 and y in Q24 (linalg/chol_q15).
 * Where a column explains little of the residual its y is small, and it is a step:
 * the prior keeps all its bits. */
static uint8_t solve_q(stlqf_state_t *s, int32_t *log_cond)
{
    stlqf_q_t *q = &s->u.q;
    uint8_t st = 0;
    int32_t prior[6];
    for (uint8_t a = 0; a < 6u; a++) {
        prior[a] = (a & 1u) ? fx_add(q->theta[a], q->theta[a - 1u], &st) : 0;
    }
    /* The rows in int32, one exponent per channel (the largest row's): v̇'s ψ̃, ½ρv²'s,
     * the time column's e of the first two, ζ. */
    int8_t peak[3];
    int32_t rows[STLQF_COLS][STLQF_ROWS];
    stlqf_align_q(s->rows.q, s->head, peak, rows);
    const int32_t *r[3] = {rows[0], rows[1], rows[4]}, *e_col[2] = {rows[2], rows[3]};
    int8_t e_r[3];
    for (uint8_t ch = 0; ch < 3u; ch++) {
        e_r[ch] = (int8_t)(peak[ch] - row_q[ch]);
    }
    int16_t x[5][STLQF_ROWS]; /* [τ v̇, v̇, τ q, q] and the residual, as X */
    int8_t e[6];
    int32_t col[STLQF_ROWS];
    for (uint8_t ch = 0; ch < 2u; ch++) {
        time_column(r[ch], e_col[ch], col); /* |τ ψ̃ + e| < 6 · 2^27 */
        e[2u * ch] = (int8_t)(e_r[ch] + weigh(q->band, col, x[2u * ch]));
        e[2u * ch + 1u] = (int8_t)(e_r[ch] + weigh(q->band, r[ch], x[2u * ch + 1u]));
    }
    int8_t e_res = residual(q, r, e_r, prior, col);
    e_res = (int8_t)(e_res + weigh(q->band, col, x[4]));
    e[4] = q->e_g[0];
    e[5] = q->e_g[1];
    const int16_t *xs[6] = {x[0], x[1], x[2], x[3], q->x_g[0], q->x_g[1]}; /* θ's */
    const int16_t *xu[6]; /* the same in the solve's order */
    for (uint8_t i = 0; i < 6u; i++) {
        xu[i] = xs[unknown(i)];
    }
    int32_t g[36], rhs[6], scale[6];
    int32_t *gi = g;
    for (uint8_t i = 0; i < 6u; i++, gi += 6) {
        /* Gi / 2^32 in Q30: diagonal < 1/2; g/cos ε's own entries are constant (θ's 4 and
         * 5, the solve's unknowns 3 and 4); nine products of at most X_LIMIT² fit int32 */
        uint8_t known = i == 3u || i == 4u ? 3u : (uint8_t)(i + 1u);
        fx_dot16_rows(xu[i], xu, gi, known, STLQF_ROWS, 2);
        for (uint8_t j = known; j <= i; j++) {
            gi[j] = q->g_gg[i + j - 6u] >> 2;
        }
    }
    fx_dot16_rows(x[4], xu, rhs, 6, STLQF_ROWS, 32 - DELTA_Q);
    for (uint8_t i = 0; i < 6u; i++) {
        int32_t *gii = &g[i * 6u + i];
        scale[i] = *gii > 0 ? *gii : ((int32_t)1 << 28); /* a column of zeros: δ = 0 */
        *gii = fx_add(*gii, fx_mul_shr(q->mu, scale[i], 30, &st), &st); /* μ <= 1: < 1 */
    }
    int16_t l[36];
    int32_t inv[6];
    if (!chol_solve_q15(g, rhs, 6, l, inv, &st)) {
        *log_cond = INT32_MAX;
        return (uint8_t)(st | STATUS_SINGULAR);
    }
    for (uint8_t i = 0; i < 6u; i++) {
        uint8_t a = unknown(i);
        int32_t step = scale_pow2(rhs[i], (int16_t)(e_res - e[a] + THETA_Q - DELTA_Q), &st);
        q->theta[a] = fx_add(prior[a], step, &st);
    }
    /* The condition estimate of the Jacobi-scaled matrix: its pivots are L_ii² / G_ii. */
    int32_t lo = INT32_MAX, hi = INT32_MIN;
    for (uint8_t i = 0; i < 6u; i++) {
        int32_t pivot = 2 * fx_log2_q24(l[i * 7u], 15) - fx_log2_q24(scale[i], 30);
        lo = pivot < lo ? pivot : lo;
        hi = pivot > hi ? pivot : hi;
    }
    *log_cond = fx_mul_shr(hi - lo, 323228497 /* log10 2, Q30 */, 30, &st);
    /* The prior's share of m̂ (docs/estimators/stlqf.md), at most 1: μ G_mm / L_mm², the
     * mass last. A rounding that saturates it says "all prior", not a saturated estimate. */
    uint8_t held_st = 0;
    int32_t pull = fx_mul_shr(q->mu, scale[STLQF_LAST], 30, &held_st); /* μ G_mm, Q30 */
    int32_t held = chol_inv_diag_q15(l, inv, 6, STLQF_LAST, pull, &held_st);
    /* The next window's μ: mu_max (mu_max / ι)² within [mu_min, mu_max], ι G_mm = L_mm²
     * - μ G_mm (Q30), so mu_max / ι = mu_max G_mm / (L_mm² - μ G_mm). */
    uint8_t mu_st = 0; /* top < info < 1: nothing saturates */
    int32_t top = fx_mul_shr(q->mu_max, scale[STLQF_LAST], 30, &mu_st);
    int32_t info = (int32_t)l[STLQF_LAST * 7u] * l[STLQF_LAST * 7u] - pull; /* Q30 */
    int32_t next = q->mu_max;
    if (q->mu_min < q->mu_max && info > top) {
        int32_t ratio = fx_div(top, 30, info, 30, 30, &mu_st); /* < 1 */
        next = fx_mul_shr(q->mu_max, fx_mul_shr(ratio, ratio, 30, &mu_st), 30, &mu_st);
    }
    q->mu = next > q->mu_min ? next : q->mu_min;
    return (uint8_t)(st | (held > q->held_max || held_st ? STATUS_ILL_CONDITIONED : 0u));
}

/* ---- both ---- */

static void stlqf_reset(void *state)
{
    stlqf_state_t *s = state;
    if (s->mode == MODE_F32) {
        float theta0[3];
        longit_initial(&s->model, theta0);
        for (uint8_t l = 0; l < 3u; l++) {
            s->u.f32.theta[2u * l] = 0.0f;
            s->u.f32.theta[2u * l + 1u] = theta0[l];
        }
        s->u.f32.mu = s->u.f32.mu_max;
        s->u.f32.jitter = 0.0f;
    } else {
        const longit_q_t *l = &s->u.q.shared;
        uint8_t st = 0;
        memset(s->u.q.theta, 0, sizeof s->u.q.theta);
        s->u.q.mu = s->u.q.mu_max;
        s->u.q.jitter = 0;
        s->u.q.theta[1] = l->m0;
        s->u.q.theta[3] = fx_rescale(l->cda0, 24, 16, &st);
        s->u.q.theta[5] = fx_mul(l->m0, 16, l->sin_eps, 30, 16, &st);
    }
    s->n_hist = s->n_rows = s->head = s->solved = 0;
    longit_reset(&s->model);
}

static uint8_t stlqf_configure(void *state, uint8_t mode, const uint8_t *params)
{
    stlqf_state_t *s = state;
    uint8_t bad = longit_check(params, mode, ranges, N_OWN);
    if (bad != 0u) {
        return bad;
    }
    if (mode == MODE_F32 ? get_f32(params + 4u * P_MU_MIN) > get_f32(params + 4u * P_MU)
                         : param_q(params, P_MU_MIN) > param_q(params, P_MU)) {
        return 1u + P_MU_MIN; /* μ adapts between mu_min and mu */
    }
    int32_t a_q[6]; /* a11 a12 a13 a22 a23 a33, Q24 */
    for (uint8_t i = 0; i < 6u; i++) {
        uint8_t st = 0;
        a_q[i] = mode == MODE_F32 ? fx_from_float(get_f32(params + 4u * (P_A11 + i)), 24, &st)
                                  : param_q(params, (uint8_t)(P_A11 + i));
    }
    const int32_t a[3][3] = {
        {a_q[0], a_q[1], a_q[2]},
        {a_q[1], a_q[3], a_q[4]},
        {a_q[2], a_q[4], a_q[5]},
    };
    int32_t band[STLQF_ROWS][3];
    if (!band_factor(band, a)) {
        return 1u + P_A11; /* A is not positive definite */
    }
    longit_configure(&s->model, params, N_OWN, mode);
    s->mode = mode;
    if (mode == MODE_F32) {
        configure_f32(&s->u.f32, &s->model, params, band);
    } else {
        bad = configure_q(&s->u.q, params, band);
        if (bad != 0u) {
            return bad;
        }
    }
    stlqf_reset(s);
    return 0;
}

/* One sample into the window: its filtered row once two came before it. */
static void push(stlqf_state_t *s, const void *x)
{
    if (s->n_hist == 2u) {
        if (s->mode == MODE_F32) {
            filter_f32(&s->u.f32, x, (const float(*)[3])s->hist.f, s->rows.f[s->head]);
        } else {
            filter_q(&s->u.q, x, (const int32_t(*)[3])s->hist.q, s->rows.q[s->head].m,
                     s->rows.q[s->head].k);
        }
        s->head = slot(s, 1);
        if (s->n_rows < STLQF_ROWS) {
            s->n_rows++;
        }
    } else {
        s->n_hist++;
    }
    memcpy(s->hist.q[1], s->hist.q[0], sizeof s->hist.q[0]);
    memcpy(s->hist.q[0], x, sizeof s->hist.q[0]);
}

/* Whether this is the first window solved since the reset, whose step of m̂ is from m0. */
static uint8_t first_window(stlqf_state_t *s)
{
    uint8_t first = !s->solved;
    s->solved = 1;
    return first;
}

/* Whether m̂'s mean step per window, over τ_jitter of time, is above jitter_max: the data fix
 * the mass, but noise moves it (docs/estimators/stlqf.md). The first window's step, from
 * m0, is not counted. */
static uint8_t noisy_f32(stlqf_state_t *s, float step)
{
    stlqf_f32_t *f = &s->u.f32;
    if (first_window(s)) {
        return 0;
    }
    f->jitter += f->jitter_a * (step - f->jitter);
    return f->jitter_max > 0.0f && f->jitter > f->jitter_max;
}

/* noisy_f32 in Q16: the step's magnitude held to 2^30 (16384 kg), so the mean stays there. */
static uint8_t noisy_q(stlqf_state_t *s, int32_t m_last)
{
    stlqf_q_t *q = &s->u.q;
    if (first_window(s)) {
        return 0;
    }
    uint8_t st = 0; /* |step - mean| < 2^30: nothing saturates */
    int32_t d = fx_sub(q->theta[1], m_last, &st);
    uint32_t mag = d < 0 ? (uint32_t)0 - (uint32_t)d : (uint32_t)d;
    mag = mag < ((uint32_t)1 << 30) ? mag : (uint32_t)1 << 30;
    q->jitter += fx_mul16((int32_t)mag - q->jitter, q->jitter_a, 15, &st);
    return q->jitter_max > 0 && q->jitter > q->jitter_max;
}

static uint8_t step_f32(stlqf_state_t *s, const uint8_t *in, uint8_t *out)
{
    float psi[3], z, log_cond = 0.0f;
    /* A non-finite sample is dropped: the window keeps its rows; one past the bounds is
     * taken clamped to them, as FIXED takes it. */
    uint8_t status = longit_inputs(&s->model, in, psi, &z);
    if (!(status & STATUS_NOT_FINITE)) {
        const float x[3] = {psi[0], psi[1], z};
        push(s, x);
        if (s->n_rows == STLQF_ROWS) {
            float m_last = s->u.f32.theta[1];
            uint8_t solved = solve_f32(s, &log_cond);
            status |= solved;
            if (!(solved & STATUS_SINGULAR) && noisy_f32(s, fabsf(s->u.f32.theta[1] - m_last))) {
                status |= STATUS_ILL_CONDITIONED;
            }
        }
    }
    const float *theta = s->u.f32.theta;
    status |= longit_outputs(&s->model, theta[1], theta[3], theta[5], out);
    put_f32(out + 12, log_cond);
    return status;
}

static uint8_t step_q(stlqf_state_t *s, const uint8_t *in, uint8_t *out)
{
    uint8_t st = 0;
    int32_t x[3], log_cond = 0;
    longit_inputs_q(&s->u.q.shared, in, x, &st);
    push(s, x);
    if (s->n_rows == STLQF_ROWS) {
        int32_t m_last = s->u.q.theta[1];
        uint8_t solved = solve_q(s, &log_cond);
        st |= solved;
        if (!(solved & STATUS_SINGULAR) && noisy_q(s, m_last)) {
            st |= STATUS_ILL_CONDITIONED;
        }
    }
    const int32_t *theta = s->u.q.theta;
    longit_outputs_q(&s->u.q.shared, theta[1], THETA_Q, theta[3], theta[5], THETA_Q, out, &st);
    put_i32(out + 12, log_cond);
    return st;
}

static uint8_t stlqf_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                          uint8_t *out_len)
{
    (void)in_len;
    stlqf_state_t *s = state;
    *out_len = 16;
    return s->mode == MODE_F32 ? step_f32(s, in, out) : step_q(s, in, out);
}

const ROM estimator_t stlqf_estimator = {
    .id = STLQF_ID,
    .name = "stlqf",
    .modes = (1u << MODE_F32) | (1u << MODE_FIXED),
    .n_inputs = 3,
    .n_outputs = 4,
    .n_params = N_PARAMS,
    .configure = stlqf_configure,
    .reset = stlqf_reset,
    .step = stlqf_step,
};
