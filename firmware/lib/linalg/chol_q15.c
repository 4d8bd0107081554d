#include "linalg/chol_q15.h"

#include "fixmath/fixmath.h"

/* (x - Σ l[k stride] y[k] 2^-15) / l_ii for k < n: one substitution row, the sum exact
 * and rounded once (fixmath's int16 × int32 dot product). */
static int32_t substitute(int32_t x, const int16_t *l, const int32_t *y, uint8_t stride_l,
                          uint8_t n, int32_t inv, uint8_t *status)
{
    int32_t s = n != 0u ? fx_sub(x, fx_dot16x32_q15(l, y, n, stride_l, status), status) : x;
    return fx_mul_shr(s, inv, 16, status); /* 1 / l_ii in Q16 */
}

uint8_t chol_solve_q15(const int32_t *a, int32_t *b, uint8_t n, int16_t *l, int32_t *inv,
                       uint8_t *status)
{
    int16_t *lj = l; /* row j of L, then row i */
    for (uint8_t j = 0; j < n; j++, lj += n) {
        const int32_t *aij = a + j * n + j;
        int16_t *li = lj;
        for (uint8_t i = j; i < n; i++, li += n, aij += n) {
            /* Q30; the sums stay below sqrt(a_ii a_jj) < 1 */
            int32_t s = j != 0u ? *aij - fx_dot16(li, lj, j) : *aij;
            if (i == j) {
                if (s < ((int32_t)1 << 10)) {
                    return 0;
                }
                lj[j] = (int16_t)fx_isqrt32((uint32_t)s);
                inv[j] = (int32_t)fx_recip31((uint16_t)lj[j]); /* l_jj >= 32 */
            } else {
                li[j] = fx_mul_shr31_q15(s, inv[j], status);
            }
        }
    }
    for (uint8_t i = 0; i < n; i++) { /* L y = b */
        b[i] = substitute(b[i], l + i * n, b, 1, i, inv[i], status);
    }
    for (uint8_t i = n; i-- > 0u;) { /* Lᵀ x = y */
        uint8_t next = (uint8_t)(i + 1u);
        b[i] = substitute(b[i], l + next * n + i, b + next, n, (uint8_t)(n - next), inv[i], status);
    }
    return 1;
}

int32_t chol_inv_diag_q15(const int16_t *l, const int32_t *inv, uint8_t n, uint8_t a, int32_t s,
                          uint8_t *status)
{
    int32_t w[CHOL_Q15_MAX_N], sum = 0;
    for (uint8_t i = a; i < n; i++) {
        int32_t x = i == a ? (int32_t)fx_isqrt32((uint32_t)(s > 0 ? s : 0)) << 15 : 0; /* √s, Q30 */
        w[i] = substitute(x, l + i * n + a, w + a, 1, (uint8_t)(i - a), inv[i], status);
        sum = fx_add(sum, fx_mul_shr(w[i], w[i], 30, status), status);
    }
    return sum;
}
