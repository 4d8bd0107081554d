#include "estimators/stlqf.h"

#include <math.h>
#include <string.h>

#include "linalg/chol_f32.h"
#include "proto/wire.h"

enum { P_CHI1, P_CHI2, P_A11, P_A12, P_A13, P_A22, P_A23, P_A33, P_MU, P_COND, N_OWN };
#define N_PARAMS (N_OWN + LONGIT_N_PARAMS)
#define CENTRE (STLQF_ROWS - 1u - STLQF_WL) /* row of the window centre */

static const param_range_t ranges[N_OWN] = {
    {0.0f, 10.0f, 24},     {0.0f, 10.0f, 24},     {-100.0f, 100.0f, 24},
    {-100.0f, 100.0f, 24}, {-100.0f, 100.0f, 24}, {-100.0f, 100.0f, 24}, {-100.0f, 100.0f, 24},
    {-100.0f, 100.0f, 24}, {0.0f, 1.0f, 30},      {1.0f, 1e9f, 0},
};

/* Time of row j from the window centre, in samples. */
static float tau(uint8_t j) { return (float)j - (float)CENTRE; }

/* R upper with bandwidth 2 and Rᵀ R = Σ_k E_kᵀ A E_k, the seven terms k stacking rows
 * k, k-1, k-2. Returns 0 when that weight is not positive definite (A is not). */
static uint8_t band_factor(float band[STLQF_ROWS][3], const float a[3][3])
{
    float m[STLQF_ROWS][3] = {{0}};
    for (uint8_t k = 2; k < STLQF_ROWS; k++) {
        const uint8_t idx[3] = {k, (uint8_t)(k - 1u), (uint8_t)(k - 2u)};
        for (uint8_t p = 0; p < 3u; p++) {
            for (uint8_t q = 0; q < 3u; q++) {
                if (idx[q] >= idx[p]) {
                    m[idx[p]][idx[q] - idx[p]] += a[p][q];
                }
            }
        }
    }
    for (uint8_t i = 0; i < STLQF_ROWS; i++) {
        for (uint8_t d = 0; d < 3u && i + d < STLQF_ROWS; d++) {
            uint8_t j = (uint8_t)(i + d);
            float s = m[i][d];
            for (uint8_t k = j >= 2u ? (uint8_t)(j - 2u) : 0u; k < i; k++) {
                s -= band[k][i - k] * band[k][j - k];
            }
            if (d == 0u) {
                if (!(s > 0.0f)) {
                    return 0;
                }
                band[i][0] = sqrtf(s);
            } else {
                band[i][d] = s / band[i][0];
            }
        }
    }
    return 1;
}

/* X = R col for a column given per row. */
static void band_apply(const float band[STLQF_ROWS][3], const float *col, float *out)
{
    for (uint8_t i = 0; i + 2u < STLQF_ROWS; i++) {
        out[i] = band[i][0] * col[i] + band[i][1] * col[i + 1u] + band[i][2] * col[i + 2u];
    }
    out[STLQF_ROWS - 2u] = band[STLQF_ROWS - 2u][0] * col[STLQF_ROWS - 2u] +
                           band[STLQF_ROWS - 2u][1] * col[STLQF_ROWS - 1u];
    out[STLQF_ROWS - 1u] = band[STLQF_ROWS - 1u][0] * col[STLQF_ROWS - 1u];
}

static void stlqf_reset(void *state)
{
    stlqf_state_t *s = state;
    float theta0[3];
    longit_initial(&s->model, theta0);
    for (uint8_t l = 0; l < 3u; l++) {
        s->theta[2u * l] = 0.0f;
        s->theta[2u * l + 1u] = theta0[l];
    }
    s->n_hist = s->n_rows = 0;
    longit_reset(&s->model);
}

static uint8_t stlqf_configure(void *state, uint8_t mode, const uint8_t *params)
{
    stlqf_state_t *s = state;
    uint8_t bad = longit_check(params, mode, ranges, N_OWN);
    if (bad != 0u) {
        return bad;
    }
    float p[N_OWN];
    for (uint8_t i = 0; i < N_OWN; i++) {
        p[i] = get_f32(params + 4u * i);
    }
    const float a[3][3] = {
        {p[P_A11], p[P_A12], p[P_A13]},
        {p[P_A12], p[P_A22], p[P_A23]},
        {p[P_A13], p[P_A23], p[P_A33]},
    };
    if (!band_factor(s->band, a)) {
        return 1u + P_A11; /* A is not positive definite */
    }
    longit_configure(&s->model, params, N_OWN, mode);
    float T = s->model.T;
    s->c1 = p[P_CHI1] / T;
    s->c2 = p[P_CHI2] / (T * T);
    s->mu = p[P_MU];
    s->cond_flag = p[P_COND];
    /* g/cos ε is constant, so its filtered columns are exact: τ g' + χ1 g'/T and g'. */
    float col[2][STLQF_ROWS];
    for (uint8_t j = 0; j < STLQF_ROWS; j++) {
        col[0][j] = (tau(j) + s->c1) * s->model.g_cos;
        col[1][j] = s->model.g_cos;
    }
    band_apply(s->band, col[0], s->x_g[0]);
    band_apply(s->band, col[1], s->x_g[1]);
    memset(s->g_gg, 0, sizeof s->g_gg);
    for (uint8_t i = 0; i < STLQF_ROWS; i++) {
        s->g_gg[0] += s->x_g[0][i] * s->x_g[0][i];
        s->g_gg[1] += s->x_g[1][i] * s->x_g[0][i];
        s->g_gg[2] += s->x_g[1][i] * s->x_g[1][i];
    }
    stlqf_reset(s);
    return 0;
}

/* One sample into the filtered rows: x + χ1 Δx/T + χ2 Δ²x/T² as differences (α x + β x₋₁
 * + γ x₋₂ with α ~ 1e4 would cancel float32's digits away), and the time column's
 * extra term χ1 x₋₁/T + 2χ2 (x₋₁ - x₋₂)/T². */
static void push(stlqf_state_t *s, const float *x)
{
    if (s->n_hist == 2u) {
        float row[STLQF_COLS];
        for (uint8_t c = 0; c < 3u; c++) {
            float d1 = x[c] - s->hist[0][c];
            float d0 = s->hist[0][c] - s->hist[1][c];
            float filtered = x[c] + s->c1 * d1 + s->c2 * (d1 - d0);
            if (c < 2u) {
                row[c] = filtered;
                row[2u + c] = s->c1 * s->hist[0][c] + 2.0f * s->c2 * d0;
            } else {
                row[4] = filtered;
            }
        }
        memmove(s->rows[0], s->rows[1], sizeof s->rows - sizeof s->rows[0]);
        memcpy(s->rows[STLQF_ROWS - 1u], row, sizeof row);
        if (s->n_rows < STLQF_ROWS) {
            s->n_rows++;
        }
    } else {
        s->n_hist++;
    }
    memcpy(s->hist[1], s->hist[0], sizeof s->hist[0]);
    memcpy(s->hist[0], x, sizeof s->hist[0]);
}

/* The window's θ: G = Xᵀ X and U = Xᵀ R ζ, Jacobi-scaled, (G_s + μ I) y = U_s + μ y_prior. */
typedef char stlqf_rows_are_nine[STLQF_ROWS == 9u ? 1 : -1]; /* dot() is written out */

static float dot(const float *a, const float *b)
{
    /* Written out: the AVR spends a tenth of each multiply-add on a loop's upkeep. */
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5] +
           a[6] * b[6] + a[7] * b[7] + a[8] * b[8];
}

static uint8_t solve(stlqf_state_t *s, float *cond)
{
    /* Φ̃'s varying columns [τ v̇, v̇, τ q, q] and ζ, then X = R Φ̃ column by column. */
    float phi[5][STLQF_ROWS], x[5][STLQF_ROWS];
    for (uint8_t j = 0; j < STLQF_ROWS; j++) {
        const float *row = s->rows[j];
        phi[0][j] = tau(j) * row[0] + row[2];
        phi[1][j] = row[0];
        phi[2][j] = tau(j) * row[1] + row[3];
        phi[3][j] = row[1];
        phi[4][j] = row[4];
    }
    for (uint8_t c = 0; c < 5u; c++) {
        band_apply(s->band, phi[c], x[c]);
    }
    const float *col[7] = {x[0], x[1], x[2], x[3], s->x_g[0], s->x_g[1], x[4]};
    float g[36], rhs[6];
    for (uint8_t a = 0; a < 6u; a++) {
        for (uint8_t b = 0; b <= a && b < 4u; b++) {
            g[a * 6u + b] = dot(col[a], col[b]);
        }
        rhs[a] = dot(col[a], col[6]);
    }
    g[4 * 6 + 4] = s->g_gg[0];
    g[5 * 6 + 4] = s->g_gg[1];
    g[5 * 6 + 5] = s->g_gg[2];
    /* (D G D + μ I) y = D U + μ y_prior with D = diag(G)^-1/2 and θ = D y is, multiplied
     * out, (G + μ diag G) θ = U + μ diag(G) θ_prior: the Jacobi-scaled system without
     * the scaling (Cholesky's rounding does not depend on it), ~12 k cycles saved. */
    float scale[6];
    for (uint8_t a = 0; a < 6u; a++) {
        float gaa = g[a * 6u + a];
        scale[a] = gaa > 0.0f ? gaa : 1.0f; /* a column of zeros (standing still) */
        /* The prior: a value where the last window's line puts it one sample later,
         * a slope zero. */
        float prior = (a & 1u) ? s->theta[a] + s->theta[a - 1u] : 0.0f;
        float pull = s->mu * scale[a];
        g[a * 6u + a] += pull;
        rhs[a] += pull * prior;
    }
    if (!chol_solve_f32(g, rhs, 6, cond)) {
        return STATUS_SINGULAR;
    }
    /* The condition estimate of the scaled matrix: its pivots are L_ii² / G_ii. */
    float lo = 0.0f, hi = 0.0f;
    for (uint8_t a = 0; a < 6u; a++) {
        float pivot = g[a * 6u + a] * g[a * 6u + a] / scale[a];
        lo = (a == 0u || pivot < lo) ? pivot : lo;
        hi = (a == 0u || pivot > hi) ? pivot : hi;
        s->theta[a] = rhs[a];
    }
    *cond = hi / lo;
    return *cond > s->cond_flag ? STATUS_ILL_CONDITIONED : 0u;
}

static uint8_t stlqf_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                          uint8_t *out_len)
{
    (void)in_len;
    stlqf_state_t *s = state;
    float psi[3], z, log_cond = 0.0f;
    /* A non-finite sample is dropped: the window keeps its rows. */
    uint8_t status = longit_inputs(&s->model, in, psi, &z);
    if (status == 0u) {
        const float x[3] = {psi[0], psi[1], z};
        push(s, x);
        if (s->n_rows == STLQF_ROWS) {
            float cond = 0.0f;
            status = solve(s, &cond);
            log_cond = status & STATUS_SINGULAR ? INFINITY : log10f(cond);
        }
    }
    status |= longit_outputs(&s->model, s->theta[1], s->theta[3], s->theta[5], out);
    put_f32(out + 12, log_cond);
    *out_len = 16;
    return status;
}

const estimator_t stlqf_estimator = {
    .id = STLQF_ID,
    .name = "stlqf",
    .modes = 1u << MODE_F32,
    .n_inputs = 3,
    .n_outputs = 4,
    .n_params = N_PARAMS,
    .configure = stlqf_configure,
    .reset = stlqf_reset,
    .step = stlqf_step,
};
