#include "linalg/chol_f32.h"

#include <math.h>

/* L (lower) with L Lᵀ = a, into l (n×n, zero above the diagonal), and 1 / L_ii into inv
 * (multiplying by it is cheaper than dividing on a soft-float core); 0 if a pivot is not
 * positive. */
static uint8_t factor(const float *a, uint8_t n, float *l, float *inv)
{
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
                inv[i] = 1.0f / l[i * n + i];
            } else {
                l[i * n + j] = s * inv[j];
            }
        }
    }
    return 1;
}

uint8_t chol_factor_f32(const float *a, uint8_t n, float *l)
{
    float inv[CHOL_F32_MAX_N];
    for (uint8_t i = 0; i < n; i++) {
        for (uint8_t j = (uint8_t)(i + 1u); j < n; j++) {
            l[i * n + j] = 0.0f;
        }
    }
    return factor(a, n, l, inv);
}

uint8_t chol_ldl_solve_f32(float *a, float *b, uint8_t n, float *inv_d)
{
    float w[CHOL_F32_MAX_N]; /* row i's l_ik d_k */
    for (uint8_t i = 0; i < n; i++) {
        float *ai = a + i * n;
        for (uint8_t j = 0; j < i; j++) {
            const float *aj = a + j * n;
            float s = ai[j];
            for (uint8_t k = 0; k < j; k++) {
                s = fmaf(-w[k], aj[k], s);
            }
            w[j] = s;
            ai[j] = s * inv_d[j];
        }
        float d = ai[i];
        for (uint8_t k = 0; k < i; k++) {
            d = fmaf(-w[k], ai[k], d);
        }
        if (!(d > 0.0f)) {
            return 0;
        }
        ai[i] = d;
        inv_d[i] = 1.0f / d;
    }
    for (uint8_t i = 0; i < n; i++) { /* L y = b */
        float s = b[i];
        for (uint8_t k = 0; k < i; k++) {
            s = fmaf(-a[i * n + k], b[k], s);
        }
        b[i] = s;
    }
    for (uint8_t i = n; i-- > 0u;) { /* D Lᵀ x = y */
        float s = b[i] * inv_d[i];
        for (uint8_t k = (uint8_t)(i + 1u); k < n; k++) {
            s = fmaf(-a[k * n + i], b[k], s);
        }
        b[i] = s;
    }
    return 1;
}

uint8_t chol_inv_f32(float *a, uint8_t n)
{
    float l[CHOL_F32_MAX_N * CHOL_F32_MAX_N] = {0}, inv[CHOL_F32_MAX_N];
    if (!factor(a, n, l, inv)) {
        return 0;
    }
    /* L⁻¹ in place (lower triangular) */
    for (uint8_t i = 0; i < n; i++) {
        l[i * n + i] = inv[i];
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
