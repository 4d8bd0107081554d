#include "linalg/chol_q15.h"

#include "fixmath/fixmath.h"

/* count more quotient bits of a restoring division by l, the remainder (below l < 2^15)
 * in 16 bits */
static inline uint16_t quotient_bits(uint16_t *rem, uint16_t l, uint8_t count)
{
    uint16_t q = 0, r = *rem;
    for (; count != 0u; count--) {
        r = (uint16_t)(r << 1);
        q = (uint16_t)(q << 1);
        if (r >= l) {
            r = (uint16_t)(r - l);
            q |= 1u;
        }
    }
    *rem = r;
    return q;
}

/* floor(2^31 / l) for 2 <= l < 2^15, restoring division with the remainder (below l) in
 * 16 bits: the dividend's bits after its leading one are zeros, so the doublings before
 * the quotient's first bit need no quotient (the first few taken at once), and the
 * quotient is built in two 16-bit halves (~250 cycles where libgcc's 32-bit division
 * costs ~600). */
static uint32_t recip31(uint16_t l)
{
    uint16_t rem = 1;
    uint8_t left = 31;
    if (l > 4096u) {
        rem = 4096;
        left = 19;
    } else if (l > 256u) {
        rem = 256;
        left = 23;
    }
    while (left != 0u && (uint16_t)(rem << 1) < l) {
        rem = (uint16_t)(rem << 1);
        left--;
    }
    uint8_t low = left > 16u ? 16u : left;
    uint16_t hi = quotient_bits(&rem, l, (uint8_t)(left - low));
    return (uint32_t)hi << 16 | quotient_bits(&rem, l, low);
}

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
                inv[j] = (int32_t)recip31((uint16_t)lj[j]); /* l_jj >= 32 */
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
