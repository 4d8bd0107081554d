#include "linalg/mat_f32.h"

/* C = A · B with B read through strides, so B and Bᵀ take the same loop. */
static void mul_strided(const float *a, const float *b, uint8_t n, uint8_t m, uint8_t p,
                        uint8_t b_row, uint8_t b_col, float *c)
{
    for (uint8_t i = 0; i < n; i++) {
        for (uint8_t j = 0; j < p; j++) {
            float acc = 0.0f;
            for (uint8_t k = 0; k < m; k++) {
                acc += a[i * m + k] * b[k * b_row + j * b_col];
            }
            c[i * p + j] = acc;
        }
    }
}

void mat_mul_f32(const float *a, const float *b, uint8_t n, uint8_t m, uint8_t p, float *c)
{
    mul_strided(a, b, n, m, p, p, 1, c);
}

void mat_mul_bt_f32(const float *a, const float *b, uint8_t n, uint8_t m, uint8_t p, float *c)
{
    mul_strided(a, b, n, m, p, 1, m, c);
}

uint8_t mat_inv2_f32(float *a)
{
    float det = a[0] * a[3] - a[1] * a[2];
    if (!(det > 1e-30f || det < -1e-30f)) {
        return 0;
    }
    float inv = 1.0f / det;
    float a0 = a[0];
    a[0] = a[3] * inv;
    a[3] = a0 * inv;
    a[1] = -a[1] * inv;
    a[2] = -a[2] * inv;
    return 1;
}
