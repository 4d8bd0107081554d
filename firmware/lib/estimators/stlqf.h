/* STLQF (seed 002, note §2): m, C_dA_f and grade from an 11-sample window, each
 * parameter linear in local time, the error filtered by α, β, γ (eq. 16 corrected)
 * and weighted by A (Table 3), the estimate at the window centre (WL samples old).
 * G = Σ_k W_kᵀ A W_k is formed as Xᵀ X, X = R Φ̃, R the banded factor of the weight A
 * spreads over the nine filtered rows; the system is Jacobi-scaled and solved by
 * Cholesky with μ pulling each value towards the previous window's and each slope
 * towards zero (host: estimators/stlqf.py).
 *
 * Inputs  v [m/s], v̇ [m/s²], z [N].  Outputs m̂ [kg], Ĉ_dA_f [m²], β̂_r [deg], log10 cond.
 * Params  χ1, χ2, a11 a12 a13 a22 a23 a33, μ, cond_flag, then longit's (ε, ρ, g, m0,
 *         C_dA_f0, T, prefilter Hz). float32. */
#ifndef VEHIL_ESTIMATORS_STLQF_H
#define VEHIL_ESTIMATORS_STLQF_H

#include <stdint.h>

#include "estimators/estimator.h"
#include "estimators/longit.h"

#define STLQF_ID 30u
#define STLQF_WL 5u
#define STLQF_ROWS (2u * STLQF_WL - 1u) /* filtered rows per window: φ̃[k] needs φ[k-2] */
#define STLQF_COLS 5u /* per row: ψ̃ and the time column's e for v̇ and ½ρv², then ζ */

typedef struct {
    longit_t model;
    float c1, c2;  /* χ1/T, χ2/T² */
    float mu, cond_flag;
    float band[STLQF_ROWS][3];    /* R(i, i + d) */
    float x_g[2][STLQF_ROWS];     /* X's columns of g/cos ε (constant: its filters are exact) */
    float g_gg[3];                /* their Gram entries */
    float hist[2][3];             /* v̇, ½ρv², z of the last two samples, newest first */
    float rows[STLQF_ROWS][STLQF_COLS]; /* oldest first */
    float theta[6];               /* [slope, value at the centre] per parameter */
    uint8_t n_hist, n_rows;
} stlqf_state_t;

extern const estimator_t stlqf_estimator;

#endif
