/* Small symmetric positive-definite systems in fixed point by LDLᵀ (no square roots):
 * the matrix in Q30 (|a_ij| < 2), L in Q24, the right side and the solution in any Q
 * (their products with L are >> 24); 1/D as a Q31 mantissa and a shift, so it keeps 30 bits at every D.
 * Products are int64 with one rounding; a result past int32 saturates and flags
 * STATUS_SATURATED. */
#ifndef VEHIL_LINALG_LDL_Q_H
#define VEHIL_LINALG_LDL_Q_H

#include <stdint.h>

#define LDL_Q_MAX_N 6u

/* Solves a x = b (a row-major n×n, its lower triangle read): x overwrites b; a's lower
 * triangle becomes L below the diagonal and D on it (Q30). Returns 0 if a pivot is
 * below 2^-15: b is then garbage. */
uint8_t ldl_solve_q(int32_t *a, int32_t *b, uint8_t n, uint8_t *status);

#endif
