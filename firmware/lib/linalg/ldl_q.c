#include "linalg/ldl_q.h"

#include "fixmath/fixmath.h"

typedef struct {
    int32_t mant; /* 2^61 / n, n = D 2^shift in [2^30, 2^31) */
    uint8_t shift;
} recip_t;

static recip_t reciprocal(int32_t d)
{
    recip_t r = {0, 0};
    while (d < ((int32_t)1 << 30)) {
        d <<= 1;
        r.shift++;
    }
    r.mant = (int32_t)((((int64_t)1 << 61) - 1) / d);
    return r;
}

/* x / D: x 2^30 / D_q30 = x · mant · 2^(shift - 31). */
static int32_t over_d(int32_t x, recip_t r, uint8_t q_less, uint8_t *status)
{
    return fx_mul_shr(x, r.mant, (uint8_t)(31u + q_less - r.shift), status);
}

uint8_t ldl_solve_q(int32_t *a, int32_t *b, uint8_t n, uint8_t *status)
{
    recip_t inv[LDL_Q_MAX_N];
    int32_t w[LDL_Q_MAX_N]; /* row j of L D, Q30 */
    for (uint8_t j = 0; j < n; j++) {
        int32_t *row = a + j * n;
        int32_t d = row[j];
        for (uint8_t k = 0; k < j; k++) {
            int32_t s = row[k];
            for (uint8_t m = 0; m < k; m++) {
                s = fx_sub(s, fx_mul_shr(w[m], a[k * n + m], 24, status), status);
            }
            w[k] = s;
            row[k] = over_d(s, inv[k], 6, status); /* L_jk = w_k / D_k, Q30 -> Q24 */
            d = fx_sub(d, fx_mul_shr(s, row[k], 24, status), status);
        }
        if (d <= ((int32_t)1 << 15)) {
            return 0;
        }
        row[j] = d;
        inv[j] = reciprocal(d);
    }
    for (uint8_t i = 0; i < n; i++) { /* L y = b */
        for (uint8_t k = 0; k < i; k++) {
            b[i] = fx_sub(b[i], fx_mul_shr(a[i * n + k], b[k], 24, status), status);
        }
    }
    for (uint8_t i = 0; i < n; i++) {
        b[i] = over_d(b[i], inv[i], 0, status);
    }
    for (uint8_t i = n; i-- > 0u;) { /* Lᵀ x = D⁻¹ y */
        for (uint8_t k = (uint8_t)(i + 1u); k < n; k++) {
            b[i] = fx_sub(b[i], fx_mul_shr(a[k * n + i], b[k], 24, status), status);
        }
    }
    return 1;
}
