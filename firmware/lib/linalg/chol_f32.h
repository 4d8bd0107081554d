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

/* Solves a x = b by LDLᵀ, L unit lower, so without square roots (~480 cycles each on the
 * AVR): x overwrites b, a gets L below its diagonal and D on it, inv_d (n entries) 1 / D_i.
 * Returns 0 if a pivot is not positive. */
uint8_t chol_ldl_solve_f32(float *a, float *b, uint8_t n, float *inv_d);

#ifdef __cplusplus
}
#endif

#endif
