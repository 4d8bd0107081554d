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

/* FIXED's constants from the Q parameters with integer arithmetic only (longit_q_t). */
static void configure_q(rls_state_t *s, const uint8_t *params)
{
    uint8_t st = 0;
    longit_q_t *l = &s->u.q.shared;
    longit_configure_q(l, params, N_OWN);
    int32_t p0_m = param_q(params, P_P0_M), p_cap = param_q(params, P_CAP);
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
    /* θ_n(0) = [m0/2048, C_dA_f0/4, m0 sin ε/1024] */
    s->u.q.theta0[0] = fx_rescale(l->m0, 16, 19, &st);
    s->u.q.theta0[1] = fx_rescale(l->cda0, 24, 28, &st);
    s->u.q.theta0[2] = fx_mul(l->m0, 16, l->sin_eps, QN, 20, &st);
}

static uint8_t rls_configure(void *state, uint8_t mode, const uint8_t *params)
{
    rls_state_t *s = state;
    uint8_t bad = longit_check(params, mode, ranges, N_OWN);
    if (bad != 0u) {
        return bad;
    }
    longit_configure(&s->model, params, N_OWN, mode);
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

static uint8_t step_q(rls_state_t *s, const uint8_t *in, uint8_t *out)
{
    int32_t *theta = s->u.q.theta, *P = s->u.q.P;
    uint8_t st = 0;
    /* The normalised regressors: v̇ in Q27 is v̇/8 in Q30, ½ρv² in Q18 /4096, z in Q16
     * /16384, g' in Q26 /16. */
    int32_t x[3];
    longit_inputs_q(&s->u.q.shared, in, x, &st);
    const int32_t psi[3] = {fx_rescale(x[0], 24, 27, &st), x[1], s->u.q.shared.g_cos};
    int32_t zn = fx_rescale(x[2], 14, 16, &st);
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
    /* Outputs: θ_n read in other Q formats is θ (m: Q19, C_dA_f: Q28, m sin: Q20). */
    longit_outputs_q(&s->u.q.shared, theta[0], QN - 11, fx_rescale(theta[1], QN - 2, 16, &st),
                     theta[2], QN - 10, out, &st);
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
