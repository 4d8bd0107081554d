/* Small symmetric positive-definite systems in fixed point by Cholesky with L in Q15:
 * for a matrix scaled so its diagonal is below 1 (Q30), |L_ij| <= 1 (Cauchy-Schwarz),
 * so L fits int16 and its sums of products are exact in int32. The right side and the
 * solution are int32 in any Q (their products with L are int64). L's 15 bits suit a
 * solve for a step that the next solve corrects (estimators/stlqf.c). Past int32 or
 * int16 a value saturates and flags STATUS_SATURATED. */
#ifndef VEHIL_LINALG_CHOL_Q15_H
#define VEHIL_LINALG_CHOL_Q15_H

#include <stdint.h>

#define CHOL_Q15_MAX_N 6u

/* Solves a x = b (a row-major n×n, Q30, its lower triangle read, diagonal < 1): x
 * overwrites b; l (n×n) gets L, its diagonal the pivots' square roots. Returns 0 if a
 * pivot is below 2^-20: b is then garbage. */
uint8_t chol_solve_q15(const int32_t *a, int32_t *b, uint8_t n, int16_t *l, uint8_t *status);

#endif
