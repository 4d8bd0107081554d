#include "estimators/rls.h"

#include <string.h>

#include "fixmath/fixmath.h"
#include "proto/wire.h"

enum { P_LAMBDA, P_P0_M, P_P0_CDA, P_CAP, N_OWN };
#define N_PARAMS (N_OWN + LONGIT_N_PARAMS)
#define QN 30 /* ψ_n, z_n, θ_n, λ */
#define QP 27 /* P */
#define QK 24 /* gains */

static const param_range_t ranges[N_OWN] = {
    {0.5f, 1.0f, 30}, {0.0f, 1e9f, 0}, {0.0f, 1e4f, 16}, {1.0f, 1e6f, 0}};

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
            s->u.q.P[4u * i] = s->u.q.p0[i];
        }
    }
}

static void rls_reset(void *state)
{
    rls_state_t *s = state;
    float theta[3];
    longit_initial(&s->model, theta);
    longit_reset(&s->model);
    if (s->mode == MODE_F32) {
        memcpy(s->u.f32.theta, theta, sizeof theta);
    } else {
        memcpy(s->u.q.theta, s->u.q.theta0, sizeof s->u.q.theta);
    }
    reset_covariance(s);
}

/* cos ε and sin ε (ε <= 0.1 rad) from their series in integers: libm's last bit differs
 * between avr-libc and the host, and FIXED must give the same bits on both. */
static void cos_sin_q30(int32_t eps, int32_t *c, int32_t *sn, uint8_t *st)
{
    int32_t e2 = fx_mul(eps, QN, eps, QN, QN, st);
    int32_t e4 = fx_mul(e2, QN, e2, QN, QN, st);
    *c = fx_add(fx_sub((int32_t)1 << QN, e2 / 2, st), e4 / 24, st);
    int32_t s3 = fx_sub((int32_t)1 << QN, fx_sub(e2 / 6, e4 / 120, st), st);
    *sn = fx_mul(eps, QN, s3, QN, QN, st);
}

/* FIXED's constants from the Q parameters with integer arithmetic only (see above). */
static void configure_q(rls_state_t *s, const uint8_t *params)
{
    uint8_t st = 0;
    const uint8_t sh = N_OWN; /* the shared parameters follow the own ones */
    int32_t p0_m = param_q(params, P_P0_M), p_cap = param_q(params, P_CAP);
    int32_t eps = param_q(params, sh + LONGIT_EPS), m0 = param_q(params, sh + LONGIT_M0);
    int32_t c, sn;
    cos_sin_q30(eps, &c, &sn, &st);
    /* P_n(0) = P(0) / scale²: 2048², 4², 1024² into Q27. */
    s->u.q.p0[0] = fx_rescale(p0_m, 22, QP, &st);
    s->u.q.p0[1] = fx_rescale(param_q(params, P_P0_CDA), 16 + 4, QP, &st);
    s->u.q.p0[2] = fx_rescale(p0_m, 20, QP, &st);
    for (uint8_t i = 0; i < 3u; i++) {
        /* Past Q27's range it saturates: the cap is then the largest P it holds. */
        s->u.q.cap[i] = fx_mul(p_cap, 0, s->u.q.p0[i], QP, QP, &st);
    }
    s->u.q.lambda = param_q(params, P_LAMBDA);
    s->u.q.inv_lambda = fx_div((int32_t)1 << QN, QN, s->u.q.lambda, QN, QN, &st);
    s->u.q.half_rho = param_q(params, sh + LONGIT_RHO) / 2;
    s->u.q.g_n = fx_div(param_q(params, sh + LONGIT_G), 24 + 4, c, QN, QN, &st); /* g'/16 */
    s->u.q.eps = eps;
    /* θ_n(0) = [m0/2048, C_dA_f0/4, m0 sin ε/1024] */
    s->u.q.theta0[0] = fx_rescale(m0, 16, 19, &st);
    s->u.q.theta0[1] = fx_rescale(param_q(params, sh + LONGIT_CDA0), 24, 28, &st);
    s->u.q.theta0[2] = fx_mul(m0, 16, sn, QN, 20, &st);
}

static uint8_t rls_configure(void *state, uint8_t mode, const uint8_t *params)
{
    rls_state_t *s = state;
    uint8_t bad = longit_check(params, mode, ranges, N_OWN);
    if (bad != 0u) {
        return bad;
    }
    longit_configure(&s->model, params, N_OWN, mode);
    if (mode == MODE_FIXED && s->model.filter) {
        return (uint8_t)(1u + N_OWN + LONGIT_PREFILTER_HZ); /* no prefilter in fixed point */
    }
    s->mode = mode;
    s->lambda = param_value(params, P_LAMBDA, mode, ranges[P_LAMBDA].q);
    float p0_m = param_value(params, P_P0_M, mode, ranges[P_P0_M].q);
    float p_cap = param_value(params, P_CAP, mode, ranges[P_CAP].q);
    s->p0[0] = s->p0[2] = p0_m;
    s->p0[1] = param_value(params, P_P0_CDA, mode, ranges[P_P0_CDA].q);
    for (uint8_t i = 0; i < 3u; i++) {
        s->cap[i] = p_cap * s->p0[i];
    }
    if (mode == MODE_FIXED) {
        configure_q(s, params);
    }
    rls_reset(s);
    return 0;
}

static uint8_t step_f32(rls_state_t *s, const uint8_t *in, uint8_t *out)
{
    float psi[3], z;
    float *theta = s->u.f32.theta, *P = s->u.f32.P;
    uint8_t status = longit_inputs(&s->model, in, psi, &z);
    if (status == 0u) {
        float pp[3];
        float denom = s->lambda, err = z;
        for (uint8_t i = 0; i < 3u; i++) {
            pp[i] = P[3u * i] * psi[0] + P[3u * i + 1u] * psi[1] + P[3u * i + 2u] * psi[2];
            denom += psi[i] * pp[i];
            err -= psi[i] * theta[i];
        }
        float inv_lambda = 1.0f / s->lambda, forget = inv_lambda;
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
    return (uint8_t)(status | longit_outputs(&s->model, theta[0], theta[1], theta[2], out));
}

/* asin x for |x| <= 1/2 (|grade| < 30°) from its series to x⁹: error < 1e-5 rad there. */
static int32_t asin_q30(int32_t x, uint8_t *status)
{
    static const int32_t c[] = {1073741824, 178956971, 80530637, 47934905, 32622364};
    int32_t x2 = fx_mul(x, QN, x, QN, QN, status);
    int32_t acc = c[4];
    for (int8_t i = 3; i >= 0; i--) {
        acc = fx_add(fx_mul(acc, QN, x2, QN, QN, status), c[i], status);
    }
    return fx_mul(acc, QN, x, QN, QN, status);
}

static uint8_t step_q(rls_state_t *s, const uint8_t *in, uint8_t *out)
{
    int32_t *theta = s->u.q.theta, *P = s->u.q.P;
    uint8_t st = 0;
    int32_t v = get_i32(in), v_dot = get_i32(in + 4), z = get_i32(in + 8);
    /* The normalised regressors: the same integers read in other Q formats (v̇ Q20 as
     * Q27 is v̇/8 in Q30, ½ρv² in Q18 is /4096, z Q12 in Q16 is /16384). */
    int32_t v2 = fx_mul(v, 16, v, 16, 16, &st);
    const int32_t psi[3] = {fx_rescale(v_dot, 20, 27, &st),
                            fx_mul(v2, 16, s->u.q.half_rho, 24, 18, &st), s->u.q.g_n};
    int32_t zn = fx_rescale(z, 12, 16, &st);
    int32_t pp[3], k[3];
    int32_t denom = fx_rescale(s->u.q.lambda, QN, QP, &st), err = zn;
    for (uint8_t i = 0; i < 3u; i++) {
        pp[i] = 0;
        for (uint8_t j = 0; j < 3u; j++) {
            pp[i] = fx_add(pp[i], fx_mul(P[3u * i + j], QP, psi[j], QN, QP, &st), &st);
        }
        denom = fx_add(denom, fx_mul(psi[i], QN, pp[i], QP, QP, &st), &st);
        err = fx_sub(err, fx_mul(psi[i], QN, theta[i], QN, QN, &st), &st);
    }
    int32_t forget = s->u.q.inv_lambda;
    for (uint8_t i = 0; i < 3u; i++) {
        k[i] = fx_div(pp[i], QP, denom, QP, QK, &st);
        theta[i] = fx_add(theta[i], fx_mul(k[i], QK, err, QN, QN, &st), &st);
        for (uint8_t j = 0; j <= i; j++) {
            P[3u * i + j] = fx_sub(P[3u * i + j], fx_mul(k[i], QK, pp[j], QP, QP, &st), &st);
        }
        if (fx_mul(P[4u * i], QP, s->u.q.inv_lambda, QN, QP, &st) > s->u.q.cap[i]) {
            forget = (int32_t)1 << QN; /* windup guard */
        }
    }
    uint8_t broken = 0;
    for (uint8_t i = 0; i < 3u; i++) {
        for (uint8_t j = 0; j <= i; j++) {
            P[3u * i + j] = fx_mul(P[3u * i + j], QP, forget, QN, QP, &st);
            P[3u * j + i] = P[3u * i + j];
        }
        broken |= P[4u * i] <= 0;
    }
    if (broken) {
        reset_covariance(s);
        st |= STATUS_SINGULAR;
    }
    /* Outputs: θ_n read in other Q formats is θ (m: ×2048, C_dA_f: ×4). */
    put_i32(out, fx_rescale(theta[0], QN - 11, 16, &st));
    put_i32(out + 4, fx_rescale(theta[1], QN - 2, 24, &st));
    int32_t ratio = 0; /* m sin / m = θ_n2 · 1024 / (θ_n0 · 2048) */
    if (theta[0] > 0) {
        ratio = fx_div(theta[2], QN + 1, theta[0], QN, QN, &st);
    }
    const int32_t half = (int32_t)1 << (QN - 1);
    if (theta[0] <= 0 || ratio > half || ratio < -half) {
        st |= STATUS_CLAMPED;
        ratio = ratio > half ? half : (ratio < -half ? -half : ratio);
    }
    int32_t grade = fx_sub(asin_q30(ratio, &st), s->u.q.eps, &st);
    put_i32(out + 8, fx_mul(grade, QN, 961263669 /* 180/π, Q24 */, 24, 20, &st));
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

const estimator_t rls_estimator = {
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
