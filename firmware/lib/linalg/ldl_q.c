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

/* x - Σ a[i sa] b[i sb] 2^-24 for i < n, summed in int64 and rounded once (a product a
 * call on the AVR, a shift another). Each term of the factorization is at most
 * sqrt(a_jj a_kk) <= 2 (Cauchy-Schwarz on L D Lᵀ), so five fit with room. */
static int32_t minus_dot(int32_t x, const int32_t *a, uint8_t sa, const int32_t *b, uint8_t sb,
                         uint8_t n, uint8_t *status)
{
    int64_t acc = (int64_t)x * ((int32_t)1 << 24);
    for (uint8_t i = 0; i < n; i++) {
        acc -= (int64_t)a[i * sa] * b[i * sb];
    }
    return fx_sat((acc + ((int64_t)1 << 23)) >> 24, status);
}

uint8_t ldl_solve_q(int32_t *a, int32_t *b, uint8_t n, uint8_t *status)
{
    recip_t inv[LDL_Q_MAX_N];
    int32_t w[LDL_Q_MAX_N]; /* row j of L D, Q30 */
    for (uint8_t j = 0; j < n; j++) {
        int32_t *row = a + j * n;
        for (uint8_t k = 0; k < j; k++) {
            w[k] = minus_dot(row[k], w, 1, a + k * n, 1, k, status);
            row[k] = over_d(w[k], inv[k], 6, status); /* L_jk = w_k / D_k, Q30 -> Q24 */
        }
        int32_t d = minus_dot(row[j], w, 1, row, 1, j, status);
        if (d <= ((int32_t)1 << 15)) {
            return 0;
        }
        row[j] = d;
        inv[j] = reciprocal(d);
    }
    for (uint8_t i = 0; i < n; i++) { /* L y = b */
        b[i] = minus_dot(b[i], a + i * n, 1, b, 1, i, status);
    }
    for (uint8_t i = 0; i < n; i++) {
        b[i] = over_d(b[i], inv[i], 0, status);
    }
    for (uint8_t i = n; i-- > 0u;) { /* Lᵀ x = D⁻¹ y */
        uint8_t next = (uint8_t)(i + 1u);
        b[i] = minus_dot(b[i], a + next * n + i, n, b + next, 1, (uint8_t)(n - next), status);
    }
    return 1;
}
