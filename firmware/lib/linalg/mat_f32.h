/* Small dense float32 matrices, row-major, sizes given at run time (no malloc: the
 * caller owns every buffer). Names and argument order after CMSIS-DSP's
 * arm_mat_*_f32: sources first, destination last. */
#ifndef VEHIL_LINALG_MAT_F32_H
#define VEHIL_LINALG_MAT_F32_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" { /* C linkage for C++ wrappers of vendored libraries */
#endif

/* C (n×p) = A (n×m) · B (m×p); C must not alias A or B. */
void mat_mul_f32(const float *a, const float *b, uint8_t n, uint8_t m, uint8_t p, float *c);

/* C (n×p) = A (n×m) · Bᵀ, B being p×m; C must not alias A or B. */
void mat_mul_bt_f32(const float *a, const float *b, uint8_t n, uint8_t m, uint8_t p, float *c);

/* Inverse of a 2×2 in place; returns 0 if singular (|det| below tiny), else 1. */
uint8_t mat_inv2_f32(float *a);

#ifdef __cplusplus
}
#endif

#endif
