#include "estimators/rls.h"

#include <string.h>

#include "fixmath/fixmath.h"
#include "proto/wire.h"
#include "rom/rom.h"

enum { P_LAMBDA, P_P0_M, P_P0_CDA, P_CAP, P_HELD, P_TREF, P_QGRADE, N_OWN };
#define N_PARAMS (N_OWN + LONGIT_N_PARAMS)
#define ONE_Q30 ((int32_t)1 << 30)

static const ROM param_range_t ranges[N_OWN] = {
    {0.5f, 1.0f, 30}, {0.0f, 1e9f, 0},  {0.0f, 1e4f, 16},
    {1.0f, 1e6f, 0},  {1e-3f, 1e4f, 16}, {0.0f, 1.0f, 30}, {0.0f, 1e6f, 8}};

/* λ per sample: as given (t_ref = 0), or a forgetting per t_ref of time raised to T / t_ref,
 * so RLS remembers as long at any sample time (docs/estimators/rls.md). */
static float per_sample_lambda(const uint8_t *params, uint8_t mode)
{
    float lambda = param_value(params, P_LAMBDA, mode, param_range_q(ranges, P_LAMBDA));
    float t_ref = param_value(params, P_TREF, mode, param_range_q(ranges, P_TREF));
    if (t_ref > 0.0f) {
        lambda = param_pow(lambda, param_value(params, N_OWN + LONGIT_T, mode, 30) / t_ref);
    }
    return lambda;
}

/* FIXED's Q formats: ψ = [v̇, ½ρv², g/cos ε] as longit gives them, θ = [m, C_dA_f, m sin]. */
static const uint8_t psi_q[3] = {24, 18, 26};
static const uint8_t theta_q[3] = {16, 20, 16};
#define ERR_Q 12 /* the innovation: ±512 kN, as m v̇ can be in a transient */

/* P̃_ij's place in the packed lower triangle. */
static const uint8_t at[3][3] = {{0, 1, 3}, {1, 2, 4}, {3, 4, 5}};

static uint32_t magnitude(int32_t x) { return x < 0 ? (uint32_t)0 - (uint32_t)x : (uint32_t)x; }

/* v >> d (arithmetic) and u << d: whole bytes, then 4, 2 and 1 bits, each a shift known at
 * compile time (the AVR loops a bit at a time on a shift known only at run time). */
static int32_t sar(int32_t v, uint8_t d)
{
    for (; d >= 8u; d -= 8u) {
        v >>= 8;
    }
    v = d & 4u ? v >> 4 : v;
    v = d & 2u ? v >> 2 : v;
    return d & 1u ? v >> 1 : v;
}

static uint32_t shl(uint32_t u, uint8_t d)
{
    for (; d >= 8u; d -= 8u) {
        u <<= 8;
    }
    u = d & 4u ? u << 4 : u;
    u = d & 2u ? u << 2 : u;
    return d & 1u ? u << 1 : u;
}

/* v 2^n, rounded half up when n < 0, for a v 2^n that fits an int32 (a shift that
 * normalises v: no overflow test). */
static int32_t scale(int32_t v, int16_t n)
{
    if (n >= 0) {
        return (int32_t)shl((uint32_t)v, (uint8_t)n);
    }
    if (n < -31) {
        return 0;
    }
    v = sar(v, (uint8_t)(-n - 1)); /* to the rounding bit, then one more */
    return (v >> 1) + (v & 1);
}

/* v 2^n: rounded half up when n < 0, saturated (flagged) when it does not fit. */
static int32_t shift(int32_t v, int16_t n, uint8_t *st)
{
    if (n >= 0 && (n > 30 || sar(v, (uint8_t)(31 - n)) != (v < 0 ? -1 : 0))) {
        if (v != 0) {
            *st |= STATUS_SATURATED;
            return v > 0 ? INT32_MAX : INT32_MIN;
        }
        return 0;
    }
    return scale(v, n);
}

/* a b 2^-n for a shift n known only at run time, rounded half up, saturated: on the AVR
 * through fixmath's assembly entry for that shift (fx_mul_shr_n, the same bits as its C
 * twin); past those shifts by a shift of the result. */
FX_INLINE int32_t mul_shr(int32_t a, int32_t b, int16_t n, uint8_t *st)
{
    if (n < 1) {
        return shift(fx_mul_shr(a, b, 1, st), (int16_t)(1 - n), st);
    }
    if (n > 62) {
        return 0; /* |a b| < 2^62 */
    }
    return fx_mul_shr_n(a, b, st, (uint8_t)n);
}

/* 1 / s for s in [1/2, 1) (Q30), in Q29 to ~30 bits (fx_recip's 5e-7 is coarse for a P near
 * singular): 1/s at s = 1/2 + i/256 (Q29), interpolated by one 16 x 16 product (within
 * 2^-16: the differences to 15 bits, the fraction to 16), then one Newton step
 * y + y (1 - s y), which squares the error: 1 - s y is then below 2^-15, so its product
 * with y is a 32 x 16 one. */
static const ROM ROM_TABLE(int32_t, 129) recip_table = {{
    1073741824, 1065418244, 1057222719, 1049152317, 1041204193, 1033375590, 1025663832,
    1018066322, 1010580540, 1003204040, 995934445, 988769449, 981706811, 974744351,
    967879954, 961111563, 954437177, 947854852, 941362695, 934958867, 928641578, 922409084,
    916259690, 910191745, 904203641, 898293814, 892460737, 886702926, 881018933, 875407347,
    869866794, 864395934, 858993459, 853658096, 848388602, 843183764, 838042399, 832963354,
    827945503, 822987745, 818089009, 813248245, 808464432, 803736570, 799063683, 794444818,
    789879043, 785365448, 780903145, 776491263, 772128952, 767815383, 763549742, 759331235,
    755159085, 751032533, 746950834, 742913262, 738919105, 734967666, 731058263, 727190230,
    723362913, 719575673, 715827883, 712118930, 708448214, 704815146, 701219150, 697659662,
    694136129, 690648007, 687194767, 683775888, 680390859, 677039180, 673720360, 670433919,
    667179386, 663956297, 660764199, 657602648, 654471207, 651369448, 648296950, 645253303,
    642238100, 639250946, 636291451, 633359233, 630453915, 627575130, 624722516, 621895717,
    619094385, 616318177, 613566757, 610839793, 608136962, 605457945, 602802428, 600170102,
    597560667, 594973825, 592409282, 589866753, 587345955, 584846611, 582368447, 579911196,
    577474594, 575058383, 572662306, 570286114, 567929560, 565592401, 563274399, 560975320,
    558694933, 556433010, 554189329, 551963669, 549755814, 547565552, 545392673, 543236970,
    541098242, 538976288, 536870912,
}};

/* 1 / s's seed (Q29): the table interpolated, within 1.6e-5. */
FX_INLINE int32_t recip_seed(int32_t s)
{
    uint32_t x = (uint32_t)s - ((uint32_t)1 << 29);
    uint16_t xh = (uint16_t)(x >> 16), xm = (uint16_t)(x >> 8); /* byte moves */
    uint8_t i = (uint8_t)(xh >> 6);                             /* x >> 22 */
    uint16_t f = (uint16_t)(xm << 2);                           /* x's bits 21..6, Q16 */
    int32_t y0 = rom_i32(ROM_AT(recip_table, i));
    uint16_t d = (uint16_t)((uint32_t)(y0 - rom_i32(ROM_AT(recip_table, i + 1u))) >> 8);
    return y0 - (int32_t)(((uint32_t)d * f) >> 8);
}

FX_INLINE int32_t reciprocal(int32_t s, uint8_t *st)
{
    int32_t y = recip_seed(s);
    int16_t e = (int16_t)(((int32_t)1 << 30) - fx_mul_shr(s, y, 29, st)); /* |e| < 2^15 */
    /* y e 2^-30 from y's top 16 bits (y < 2^30 + 1): within 2^-15 of |e|, below y's LSB */
    uint16_t y15 = (uint16_t)((uint16_t)((uint32_t)y >> 16) << 1 | (uint16_t)y >> 15);
    uint32_t p = (uint32_t)((int32_t)y15 * e + 0x4000);
    return y + (int16_t)((p << 1) >> 16); /* p >> 15 by a bit and two bytes */
}

/* m sin / m in Q30 for m > 0 (both Q16): m as m_n 2^(n - 16), m_n in [1/2, 1). While the
 * ratio is within ±1/2, the seed's 1.6e-5 moves asin by under 1e-5 rad (5e-4°; 2e-5° on a
 * 1° road); past it, where asin's slope grows without bound, the full reciprocal. */
static int32_t ratio_q30(int32_t m_sin, int32_t m, uint8_t *st)
{
    uint8_t n = longit_bit_length((uint32_t)m);
    int32_t m_n = scale(m, (int16_t)(30 - n));
    int32_t r = mul_shr(m_sin, recip_seed(m_n), (int16_t)(n - 1), st);
    if (r > (ONE_Q30 >> 1) || r < -(ONE_Q30 >> 1)) {
        r = mul_shr(m_sin, reciprocal(m_n, st), (int16_t)(n - 1), st);
    }
    return r;
}

/* A positive value v 2^-q as P̃ (Q30, in [1/4, 1)) and an exponent e, v = P̃ 2^(2e); 0 stays
 * 0. Configure time only: int64 is fine there. */
static void to_scaled(int64_t v, uint8_t q, int32_t *mant, int8_t *e)
{
    *mant = 0;
    *e = 0;
    if (v <= 0) {
        return;
    }
    uint8_t n = 0;
    while ((v >> n) != 0) {
        n++;
    }
    *e = (int8_t)(((int16_t)n - q + 1) >> 1); /* arithmetic: floor */
    int16_t up = (int16_t)(30 - q - 2 * *e);
    *mant = (int32_t)(up >= 0 ? v << up : (v + ((int64_t)1 << (-up - 1))) >> -up);
}

static void reset_covariance(rls_state_t *s)
{
    if (s->mode == MODE_F32) {
        memset(s->u.f32.P, 0, sizeof s->u.f32.P);
        for (uint8_t i = 0; i < 3u; i++) {
            s->u.f32.P[4u * i] = s->p0[i];
        }
    } else {
        memset(s->u.q.P, 0, sizeof s->u.q.P);
        for (uint8_t i = 0; i < 3u; i++) {
            s->u.q.P[at[i][i]] = s->u.q.p0[i];
            s->u.q.e[i] = s->u.q.e_p0[i];
        }
        s->u.q.l = s->u.q.lambda;
    }
}

static void rls_reset(void *state)
{
    rls_state_t *s = state;
    longit_reset(&s->model);
    if (s->mode == MODE_F32) {
        longit_initial(&s->model, s->u.f32.theta);
    } else {
        uint8_t st = 0;
        const longit_q_t *l = &s->u.q.shared;
        s->u.q.theta[0] = l->m0;
        s->u.q.theta[1] = fx_rescale(l->cda0, 24, theta_q[1], &st);
        s->u.q.theta[2] = fx_mul(l->m0, 16, l->sin_eps, 30, theta_q[2], &st);
    }
    reset_covariance(s);
}

/* FIXED's constants from the Q parameters with integer arithmetic only (longit_q_t). */
static void configure_q(rls_state_t *s, const uint8_t *params)
{
    longit_configure_q(&s->u.q.shared, params, N_OWN);
    int64_t p_cap = param_q(params, P_CAP); /* Q0 */
    const int64_t p0[3] = {param_q(params, P_P0_M), param_q(params, P_P0_CDA),
                           param_q(params, P_P0_M)};
    const uint8_t p0_q[3] = {0, 16, 0};
    int64_t held = param_q(params, P_HELD); /* Q16 */
    uint8_t sat = 0; /* λ in [0.5, 1] (rls_configure checks it): within Q30's range */
    int32_t lambda = param_q(params, P_TREF) > 0
                         ? fx_from_float(per_sample_lambda(params, MODE_FIXED), 30, &sat)
                         : param_q(params, P_LAMBDA);
    for (uint8_t i = 0; i < 3u; i++) {
        to_scaled(p0[i], p0_q[i], &s->u.q.p0[i], &s->u.q.e_p0[i]);
        to_scaled(p0[i] * p_cap, p0_q[i], &s->u.q.cap[i], &s->u.q.e_cap[i]);
        /* P_ii > held_max P(0)_ii as P̃_ii 4^e_i > (held_max P(0)_ii / λ) l (P = (λ / l) P̃) */
        int32_t *h = &s->u.q.held[i];
        int8_t *e = &s->u.q.e_held[i];
        uint8_t st = 0;
        to_scaled(held * p0[i], (uint8_t)(16u + p0_q[i]), h, e);
        *h = fx_div(*h, 30, lambda, 30, 30, &st); /* in [1/4, 2) */
        if (*h >= ONE_Q30) {
            *h = (*h + 2) >> 2;
            (*e)++;
        }
    }
    /* θ3's random walk, q_grade T a step before the forgetting: P̃_33 += (q_grade T / λ) l
     * 2^(-2 e_3) (P = (λ / l) P̃ 4^e), the constant as P̃ (Q30) 4^e_walk; q_grade (Q8) times
     * T (Q30) is Q38, below 2^58 */
    int64_t qt = (int64_t)param_q(params, P_QGRADE) * param_q(params, N_OWN + LONGIT_T);
    int32_t mant;
    to_scaled(qt, 38, &mant, &s->u.q.e_walk);
    uint8_t st = 0;
    mant = mant != 0 ? fx_div(mant, 30, lambda, 30, 30, &st) : 0; /* in [1/4, 2) */
    if (mant >= ONE_Q30) {
        mant = (mant + 2) >> 2;
        s->u.q.e_walk++;
    }
    s->u.q.walk = (uint16_t)((mant + (1 << 14)) >> 15); /* Q15, in [1/4, 1] */
    s->u.q.lambda = lambda;
    s->u.q.g_cos = fx_ufactor((uint32_t)s->u.q.shared.g_cos, 30);
}

static uint8_t rls_configure(void *state, uint8_t mode, const uint8_t *params)
{
    rls_state_t *s = state;
    uint8_t bad = longit_check(params, mode, ranges, N_OWN);
    if (bad != 0u) {
        return bad;
    }
    float lambda = per_sample_lambda(params, mode);
    if (lambda < 0.5f) {
        return (uint8_t)(P_TREF + 1u); /* λ^(T / t_ref) below λ's range: FIXED's l needs it */
    }
    longit_configure(&s->model, params, N_OWN, mode);
    s->mode = mode;
    s->lambda = lambda;
    float p0_m = param_value(params, P_P0_M, mode, param_range_q(ranges, P_P0_M));
    float p_cap = param_value(params, P_CAP, mode, param_range_q(ranges, P_CAP));
    s->p0[0] = s->p0[2] = p0_m;
    s->p0[1] = param_value(params, P_P0_CDA, mode, param_range_q(ranges, P_P0_CDA));
    float held = param_value(params, P_HELD, mode, param_range_q(ranges, P_HELD));
    s->walk = param_value(params, P_QGRADE, mode, param_range_q(ranges, P_QGRADE)) *
              param_value(params, N_OWN + LONGIT_T, mode, 30);
    for (uint8_t i = 0; i < 3u; i++) {
        s->cap[i] = p_cap * s->p0[i];
        s->held[i] = held * s->p0[i];
    }
    if (mode == MODE_FIXED) {
        configure_q(s, params);
    }
    rls_reset(s);
    return 0;
}

__attribute__((noinline)) static uint8_t step_f32(rls_state_t *s, const uint8_t *in, uint8_t *out)
{
    float psi[3], z;
    float *theta = s->u.f32.theta, *P = s->u.f32.P;
    uint8_t status = longit_past_bounds(in); /* as FIXED: not learnt from */
    if (status == 0u) {
        status = longit_inputs(&s->model, in, psi, &z);
    }
    if (status == 0u) {
        float pp[3];
        float denom = s->lambda, err = z;
        for (uint8_t i = 0; i < 3u; i++) {
            pp[i] = P[3u * i] * psi[0] + P[3u * i + 1u] * psi[1] + P[3u * i + 2u] * psi[2];
            denom += psi[i] * pp[i];
            err -= psi[i] * theta[i];
        }
        float inv_lambda = 1.0f / s->lambda, forget = inv_lambda;
        P[8] += s->walk; /* θ3's random walk, before the forgetting */
        for (uint8_t i = 0; i < 3u; i++) {
            float k = pp[i] / denom;
            theta[i] += k * err;
            /* P - K (Pψ)ᵀ, one triangle, so P stays symmetric. */
            for (uint8_t j = 0; j <= i; j++) {
                P[3u * i + j] -= k * pp[j];
            }
            if (P[4u * i] * inv_lambda > s->cap[i]) {
                forget = 1.0f; /* windup guard: no forgetting this step */
            }
        }
        uint8_t broken = 0;
        for (uint8_t i = 0; i < 3u; i++) {
            for (uint8_t j = 0; j <= i; j++) {
                P[3u * i + j] *= forget;
                P[3u * j + i] = P[3u * i + j];
            }
            broken |= !(P[4u * i] > 0.0f);
        }
        if (broken) { /* round-off broke P: start it again */
            reset_covariance(s);
            status = STATUS_SINGULAR;
        }
    }
    for (uint8_t i = 0; i < 3u; i++) {
        if (P[4u * i] > s->held[i]) { /* more prior than data (rls.md) */
            status |= STATUS_ILL_CONDITIONED;
        }
    }
    return (uint8_t)(status | longit_outputs(&s->model, theta[0], theta[1], theta[2], out));
}

/* P̃_ii back into [1/4, 1) by moving e_i (row and column i shift); 0 if a variance is
 * not positive (round-off broke P). */
static uint8_t renormalise(int32_t *P, int8_t *e, uint8_t *st)
{
    for (uint8_t i = 0; i < 3u; i++) {
        int32_t *d = &P[at[i][i]];
        /* in [1/4, 1) (one unsigned compare), or P̃_ii 4^k, e_i - k: up by k = (30 - its
         * bit length) / 2 at once (exact, and a row that saturates saturates the same as
         * step by step), or down by one */
        if ((uint32_t)*d - (uint32_t)(ONE_Q30 >> 2) >= (uint32_t)(ONE_Q30 - (ONE_Q30 >> 2))) {
            if (*d <= 0) {
                return 0;
            }
            int8_t k =
                *d >= ONE_Q30 ? -1 : (int8_t)((30u - longit_bit_length((uint32_t)*d)) / 2u);
            for (uint8_t j = 0; j < 3u; j++) {
                int32_t *p = &P[at[i][j]];
                *p = shift(*p, (int16_t)(j == i ? 2 * k : k), st);
            }
            e[i] = (int8_t)(e[i] - k);
        }
    }
    return 1;
}

/* Whether P̃_ii 4^e_i > m 4^e l for a threshold m 4^e (m in [1/4, 1)), P̃_ii renormalised:
 * the windup guard's P_ii / λ > cap and ILL_CONDITIONED's P_ii > held_max P(0)_ii. Only
 * when the exponents are close is l multiplied in. */
FX_INLINE uint8_t above(const rls_state_t *s, uint8_t i, int32_t m, int8_t e, uint8_t *st)
{
    int8_t k = (int8_t)(s->u.q.e[i] - e);
    if (k < -1 || k > 1) {
        return k > 1; /* P̃ 16 >= 4 > m l, or P̃ / 16 < 1/16 <= m l */
    }
    int32_t p = s->u.q.P[at[i][i]];
    int32_t t = fx_mul_shr(m, s->u.q.l, 30, st); /* in [1/16, 1) */
    return k == 0 ? p > t : (k > 0 ? p > (t >> 2) : (p >> 2) > t);
}

/* θ += 2^(e - k) t err and P̃ -= t ŵᵀ 2^-n_p, k = top + g - gw and n_p = 27 - 2 gw + g
 * (update_q's names): its own function, so that neither frame passes the 63 bytes the
 * AVR reaches from Y in one instruction. */
__attribute__((noinline)) static void correct(rls_state_t *s, const int32_t *t, const int32_t *w,
                                              int32_t err, int16_t k, int16_t n_p, uint8_t *st)
{
    int32_t *theta = s->u.q.theta, *P = s->u.q.P;
    const int8_t *e = s->u.q.e;
    /* θ += 2^(e - k) t err (t Q27, err Q12): one product, rounded once at θ's Q; written
     * out, as P̃'s update below */
    int16_t n = (int16_t)(27 + ERR_Q + k);
    theta[0] = fx_add(theta[0], mul_shr(t[0], err, (int16_t)(n - theta_q[0] - e[0]), st), st);
    theta[1] = fx_add(theta[1], mul_shr(t[1], err, (int16_t)(n - theta_q[1] - e[1]), st), st);
    theta[2] = fx_add(theta[2], mul_shr(t[2], err, (int16_t)(n - theta_q[2] - e[2]), st), st);
    /* P̃ - w̃ w̃ᵀ / s = P̃ - t ŵᵀ 2^(2 gw - g), whose entries are at most sqrt(P̃_ii P̃_jj) < 1,
     * written out in P's packed order (the lower triangle row by row): the AVR then reaches
     * every operand at a constant offset */
    P[0] = fx_sub(P[0], mul_shr(t[0], w[0], n_p, st), st);
    P[1] = fx_sub(P[1], mul_shr(t[1], w[0], n_p, st), st);
    P[2] = fx_sub(P[2], mul_shr(t[1], w[1], n_p, st), st);
    P[3] = fx_sub(P[3], mul_shr(t[2], w[0], n_p, st), st);
    P[4] = fx_sub(P[4], mul_shr(t[2], w[1], n_p, st), st);
    P[5] = fx_sub(P[5], mul_shr(t[2], w[2], n_p, st), st);
}

/* θ3's random walk: P̃_33 += walk l 4^(e_walk - e_3) (configure_q), walk l by their top 16
 * bits (within 2^-14 of q_grade: a tuning). Where the walk's scale is above P̃_33's (as
 * usual: the walk dominates P_33 before each sample), the sum is formed at e_walk and row
 * and column 3 are shifted once, straight to their renormalised place. */
static void walk(rls_state_t *s)
{
    int32_t *P = s->u.q.P;
    int8_t *e3 = &s->u.q.e[2];
    int8_t k = (int8_t)(s->u.q.e_walk - *e3);
    int32_t w = (int32_t)fx_umul16x16(s->u.q.walk, (uint16_t)((uint32_t)s->u.q.l >> 15));
    if (k <= 0) {
        P[5] += scale(w, (int16_t)(2 * k)); /* each below 1: renormalise takes the sum */
        return;
    }
    int32_t d = scale(P[5], (int16_t)(-2 * k)) + w; /* in [1/16, 2) at e_walk: w >= 1/16 */
    int8_t r = d >= ONE_Q30 ? -1 : (d >= (ONE_Q30 >> 2) ? 0 : 1);
    P[3] = scale(P[3], (int16_t)(r - k));
    P[4] = scale(P[4], (int16_t)(r - k));
    P[5] = scale(d, (int16_t)(2 * r));
    *e3 = (int8_t)(s->u.q.e_walk - r);
}

/* The RLS update with P as P̃ 2^(e_i + e_j) (rls.h): u = 2^e ψ as ũ 2^top (Q30, its
 * largest entry in [1/2, 1)), w̃ = P̃ ũ, so Pψ = 2^(e + top) w̃ and λ + ψᵀPψ =
 * 2^(2 top) s, s = l 2^(-2 top) + ũᵀw̃, held as s_m 2^g; the gain is
 * k = 2^(e - top) w̃ / s, and P - Pψ(Pψ)ᵀ/d is P̃ - w̃ w̃ᵀ / s in P̃'s units. */
__attribute__((noinline)) static void update_q(rls_state_t *s, const int32_t *x, uint8_t *status)
{
    int32_t *theta = s->u.q.theta, *P = s->u.q.P;
    int8_t *e = s->u.q.e;
    uint8_t st = 0;
    int32_t u[3] = {x[0], x[1], s->u.q.shared.g_cos}, w[3]; /* ψ, then ũ, then t */
    int32_t *t = u;
    int32_t err = fx_rescale(x[2], 14, ERR_Q, &st);
    err = fx_sub(err, fx_mul_shr(u[0], theta[0], 24 + 16 - ERR_Q, &st), &st);
    err = fx_sub(err, fx_mul_shr(u[1], theta[1], 18 + 20 - ERR_Q, &st), &st);
    /* g / cos ε to 16 bits: θ3 absorbs its 2^-17 (the grade within 8e-6 of itself) */
    err = fx_sub(err, fx_smul_f(theta[2], s->u.q.g_cos), &st);

    /* top: the largest bit length of |ψ_j| 2^e_j; g/cos ε (g in [9, 10.5]) has 30 in Q26 */
    int16_t top = (int16_t)(30 - 26 + e[2]);
    for (uint8_t j = 0; j < 2u; j++) {
        if (u[j] != 0) {
            int16_t b = (int16_t)(longit_bit_length(magnitude(u[j])) - psi_q[j] + e[j]);
            top = b > top ? b : top;
        }
    }
    for (uint8_t j = 0; j < 3u; j++) {
        u[j] = scale(u[j], (int16_t)(30 - psi_q[j] + e[j] - top)); /* |ψ_j| 2^e_j <= 2^top */
    }
    /* w̃ = P̃ ũ, Q29 (|P̃_ij| < 1, |ũ_j| < 1), written out: the AVR pays for at[][] lookups. */
    w[0] = fx_mul_shr(P[0], u[0], 31, &st) + fx_mul_shr(P[1], u[1], 31, &st) +
           fx_mul_shr(P[3], u[2], 31, &st);
    w[1] = fx_mul_shr(P[1], u[0], 31, &st) + fx_mul_shr(P[2], u[1], 31, &st) +
           fx_mul_shr(P[4], u[2], 31, &st);
    w[2] = fx_mul_shr(P[3], u[0], 31, &st) + fx_mul_shr(P[4], u[1], 31, &st) +
           fx_mul_shr(P[5], u[2], 31, &st);
    uint32_t peak = magnitude(w[0]) | magnitude(w[1]) | magnitude(w[2]);
    /* w̃ = ŵ 2^gw, ŵ Q30 with its largest entry in [1/2, 1): once the estimate has
     * converged ψ points where P is small, and w̃ and its square terms below are tiny. */
    uint8_t n_w = longit_bit_length(peak);
    int16_t gw = (int16_t)(n_w - 29);
    int32_t q = 0; /* ũᵀŵ, Q27: <= 3 */
    for (uint8_t i = 0; i < 3u; i++) {
        w[i] = scale(w[i], (int16_t)(30 - n_w));
        q += fx_mul_shr(u[i], w[i], 33, &st);
    }
    q = q > 0 ? q : 0;
    /* s = l 2^(-2 top) + q 2^gw as s_m 2^g, s_m in [1/8, 1) (Q30) as each term is below
     * 2^(g-1), then in [1/2, 1). */
    int16_t g = (int16_t)(-2 * top);
    int16_t gq = (int16_t)(longit_bit_length((uint32_t)q) - 27 + gw);
    g = (int16_t)((q != 0 && gq > g ? gq : g) + 1);
    int32_t s_m = scale(s->u.q.l, (int16_t)(-2 * top - g)) + scale(q, (int16_t)(3 - g + gw));
    while (s_m < (ONE_Q30 >> 1)) { /* from [1/8, 1) into [1/2, 1) */
        s_m *= 2;
        g--;
    }
    int32_t r = reciprocal(s_m, &st); /* Q29, in (1, 2] */
    for (uint8_t i = 0; i < 3u; i++) {
        t[i] = fx_mul_shr(w[i], r, 32, &st); /* ŵ / s_m, Q27: < 2 */
    }
    correct(s, t, w, err, (int16_t)(top + g - gw), (int16_t)(27 - 2 * gw + g), &st);
    if (s->u.q.walk != 0) {
        walk(s);
    }
    uint8_t forget = renormalise(P, e, &st);
    if (!forget) {
        reset_covariance(s);
        st |= STATUS_SINGULAR;
    }
    for (uint8_t i = 0; i < 3u; i++) {
        forget = above(s, i, s->u.q.cap[i], s->u.q.e_cap[i], &st) ? 0u : forget; /* windup */
    }
    if (forget) { /* P / λ as l λ */
        s->u.q.l = fx_mul_shr(s->u.q.l, s->u.q.lambda, 30, &st);
        if (s->u.q.l < (ONE_Q30 >> 2)) { /* l 4 and every e_i + 1: P unchanged */
            s->u.q.l *= 4;
            for (uint8_t i = 0; i < 3u; i++) {
                e[i]++;
            }
        }
    }
    *status |= st;
}

static uint8_t step_q(rls_state_t *s, const uint8_t *in, uint8_t *out)
{
    const int32_t *theta = s->u.q.theta;
    uint8_t st = 0;
    int32_t x[3];
    longit_inputs_q(&s->u.q.shared, in, x, &st);
    if (!(st & STATUS_CLAMPED)) { /* a sample past FIXED's bounds would teach a wrong θ */
        update_q(s, x, &st);
    }
    for (uint8_t i = 0; i < 3u; i++) {
        if (above(s, i, s->u.q.held[i], s->u.q.e_held[i], &st)) { /* more prior than data */
            st |= STATUS_ILL_CONDITIONED;
        }
    }
    int32_t ratio = 0;
    if (theta[0] > 0) {
        /* a ratio past Q30's ±2 is past asin's ±1: CLAMPED there, as float32 says it */
        uint8_t past = 0;
        ratio = ratio_q30(theta[2], theta[0], &past);
        st |= past ? STATUS_CLAMPED : 0u;
    } else {
        st |= STATUS_CLAMPED;
    }
    longit_outputs_ratio_q(&s->u.q.shared, theta[0], fx_rescale(theta[1], theta_q[1], 16, &st),
                           ratio, out, &st);
    return st;
}

static uint8_t rls_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                        uint8_t *out_len)
{
    (void)in_len;
    rls_state_t *s = state;
    *out_len = 12;
    return s->mode == MODE_F32 ? step_f32(s, in, out) : step_q(s, in, out);
}

const ROM estimator_t rls_estimator = {
    .id = RLS_ID,
    .name = "rls",
    .modes = (1u << MODE_F32) | (1u << MODE_FIXED),
    .n_inputs = 3,
    .n_outputs = 3,
    .n_params = N_PARAMS,
    .configure = rls_configure,
    .reset = rls_reset,
    .step = rls_step,
};
