/* Small symmetric positive-definite systems in fixed point by Cholesky with L in Q15:
 * for a matrix scaled so its diagonal is below 1 (Q30), |L_ij| <= 1 (Cauchy-Schwarz),
 * so L fits int16 and its sums of products are exact in int32. The right side and the
 * solution are int32 in any Q (their products with L are int64). L's 15 bits suit a
 * solve for a step that the next solve corrects (estimators/stlqf.c). Past int32 or
 * int16 a value saturates and flags STATUS_SATURATED. */
#ifndef VEHIL_LINALG_CHOL_Q15_H
#define VEHIL_LINALG_CHOL_Q15_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" { /* C linkage for C++ wrappers of vendored libraries */
#endif

#define CHOL_Q15_MAX_N 6u

/* Solves a x = b (a row-major n×n, Q30, its lower triangle read, diagonal < 1): x
 * overwrites b; l (n×n) gets L, its diagonal the pivots' square roots, and inv (n) 1 / L_ii
 * in Q16 (L_ii in Q15). Returns 0 if a
 * pivot is below 2^-20: b is then garbage. */
uint8_t chol_solve_q15(const int32_t *a, int32_t *b, uint8_t n, int16_t *l, int32_t *inv,
                       uint8_t *status);

/* s [(L Lᵀ)⁻¹]_aa in Q30 from chol_solve_q15's factor l and inv, for a caller whose s (Q30) keeps
 * it at most 1 (as s = μ a_aa does for a + μ diag(a)): ‖L⁻¹ √s e_a‖² by a forward
 * substitution from row a, every entry within ±1. */
int32_t chol_inv_diag_q15(const int16_t *l, const int32_t *inv, uint8_t n, uint8_t a, int32_t s,
                          uint8_t *status);

#ifdef __cplusplus
}
#endif

#endif
