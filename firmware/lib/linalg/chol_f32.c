#include "linalg/chol_f32.h"

#include <math.h>

uint8_t chol_inv_f32(float *a, uint8_t n)
{
    float l[CHOL_F32_MAX_N * CHOL_F32_MAX_N] = {0};
    /* A = L Lᵀ */
    for (uint8_t i = 0; i < n; i++) {
        for (uint8_t j = 0; j <= i; j++) {
            float s = a[i * n + j];
            for (uint8_t k = 0; k < j; k++) {
                s -= l[i * n + k] * l[j * n + k];
            }
            if (i == j) {
                if (!(s > 0.0f)) {
                    return 0;
                }
                l[i * n + i] = sqrtf(s);
            } else {
                l[i * n + j] = s / l[j * n + j];
            }
        }
    }
    /* L⁻¹ in place (lower triangular) */
    for (uint8_t i = 0; i < n; i++) {
        l[i * n + i] = 1.0f / l[i * n + i];
        for (uint8_t j = 0; j < i; j++) {
            float s = 0.0f;
            for (uint8_t k = j; k < i; k++) {
                s += l[i * n + k] * l[k * n + j];
            }
            l[i * n + j] = -s * l[i * n + i];
        }
    }
    /* A⁻¹ = L⁻ᵀ L⁻¹ */
    for (uint8_t i = 0; i < n; i++) {
        for (uint8_t j = 0; j <= i; j++) {
            float s = 0.0f;
            for (uint8_t k = i; k < n; k++) {
                s += l[k * n + i] * l[k * n + j];
            }
            a[i * n + j] = s;
            a[j * n + i] = s;
        }
    }
    return 1;
}
