/* Small symmetric positive-definite float32 systems by Cholesky (row-major,
 * n <= CHOL_F32_MAX_N, no malloc). */
#ifndef VEHIL_LINALG_CHOL_F32_H
#define VEHIL_LINALG_CHOL_F32_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" { /* C linkage for C++ wrappers of vendored libraries */
#endif

#define CHOL_F32_MAX_N 7u

/* L (lower, zero above the diagonal) with L Lᵀ = a into l; returns 0 if a pivot is not
 * positive. l must not alias a. */
uint8_t chol_factor_f32(const float *a, uint8_t n, float *l);

/* a (n×n, SPD) -> a⁻¹ in place; returns 0 if a pivot is not positive (a is then garbage). */
uint8_t chol_inv_f32(float *a, uint8_t n);

/* Solves a x = b: x overwrites b, a is overwritten by its factor L and inv (n entries)
 * gets 1 / L_ii. Returns 0 if a pivot is not positive. */
uint8_t chol_solve_f32(float *a, float *b, uint8_t n, float *inv);

/* [(L Lᵀ)⁻¹]_aa = ‖L⁻¹ e_a‖² from chol_solve_f32's factor l (n×n, lower) and inv: a
 * forward substitution from row a. */
float chol_inv_diag_f32(const float *l, const float *inv, uint8_t n, uint8_t a);

#ifdef __cplusplus
}
#endif

#endif
