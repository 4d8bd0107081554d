#include "estimators/rls.h"

#include <string.h>

#include "proto/wire.h"

enum { P_LAMBDA, P_P0_M, P_P0_CDA, P_CAP, N_OWN };
#define N_PARAMS (N_OWN + LONGIT_N_PARAMS)

static const param_range_t ranges[N_OWN] = {
    {0.5f, 1.0f, 30}, {0.0f, 1e9f, 0}, {0.0f, 1e4f, 16}, {1.0f, 1e6f, 0}};

static void reset_covariance(rls_state_t *s)
{
    memset(s->P, 0, sizeof s->P);
    s->P[0] = s->P[8] = s->p0_m;
    s->P[4] = s->p0_cda;
}

static void rls_reset(void *state)
{
    rls_state_t *s = state;
    longit_initial(&s->model, s->theta);
    longit_reset(&s->model);
    reset_covariance(s);
    for (uint8_t i = 0; i < 3u; i++) {
        s->cap[i] = s->p_cap * s->P[4u * i];
    }
}

static uint8_t rls_configure(void *state, uint8_t mode, const uint8_t *params)
{
    rls_state_t *s = state;
    uint8_t bad = longit_check(params, mode, ranges, N_OWN);
    if (bad != 0u) {
        return bad;
    }
    s->lambda = get_f32(params + 4u * P_LAMBDA);
    s->p0_m = get_f32(params + 4u * P_P0_M);
    s->p0_cda = get_f32(params + 4u * P_P0_CDA);
    s->p_cap = get_f32(params + 4u * P_CAP);
    longit_configure(&s->model, params, N_OWN);
    rls_reset(s);
    return 0;
}

static uint8_t rls_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                        uint8_t *out_len)
{
    (void)in_len;
    rls_state_t *s = state;
    float psi[3], z;
    uint8_t status = longit_inputs(&s->model, in, psi, &z);
    if (status == 0u) {
        float pp[3];
        float denom = s->lambda, err = z;
        for (uint8_t i = 0; i < 3u; i++) {
            pp[i] = s->P[3u * i] * psi[0] + s->P[3u * i + 1u] * psi[1] + s->P[3u * i + 2u] * psi[2];
            denom += psi[i] * pp[i];
            err -= psi[i] * s->theta[i];
        }
        float inv_lambda = 1.0f / s->lambda, forget = inv_lambda;
        for (uint8_t i = 0; i < 3u; i++) {
            float k = pp[i] / denom;
            s->theta[i] += k * err;
            /* P - K (Pψ)ᵀ, one triangle, so P stays symmetric. */
            for (uint8_t j = 0; j <= i; j++) {
                s->P[3u * i + j] -= k * pp[j];
            }
            if (s->P[4u * i] * inv_lambda > s->cap[i]) {
                forget = 1.0f; /* windup guard: no forgetting this step */
            }
        }
        uint8_t broken = 0;
        for (uint8_t i = 0; i < 3u; i++) {
            for (uint8_t j = 0; j <= i; j++) {
                s->P[3u * i + j] *= forget;
                s->P[3u * j + i] = s->P[3u * i + j];
            }
            broken |= !(s->P[4u * i] > 0.0f);
        }
        if (broken) { /* round-off broke P: start it again */
            reset_covariance(s);
            status = STATUS_SINGULAR;
        }
    }
    status |= longit_outputs(&s->model, s->theta[0], s->theta[1], s->theta[2], out);
    *out_len = 12;
    return status;
}

const estimator_t rls_estimator = {
    .id = RLS_ID,
    .name = "rls",
    .modes = 1u << MODE_F32,
    .n_inputs = 3,
    .n_outputs = 3,
    .n_params = N_PARAMS,
    .configure = rls_configure,
    .reset = rls_reset,
    .step = rls_step,
};
