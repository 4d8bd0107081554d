#include "estimators/ev_ukf.h"

#include <math.h>
#include <string.h>

#include "linalg/chol_f32.h"
#include "proto/wire.h"

enum { P_ALPHA = EV_N_FORCE_PARAMS, N_OWN };
static const ROM param_range_t own_ranges[N_OWN] = {EV_FORCE_RANGES, {1e-4f, 1.0f, 16}};

static void ev_ukf_reset(void *state)
{
    ev_ukf_state_t *s = state;
    ev_model_reset(&s->model);
    ev_prior(&s->model, EV_NX, s->p0_f, s->x, s->P);
    s->started = 0;
}

static uint8_t ev_ukf_configure(void *state, uint8_t mode, const uint8_t *params)
{
    ev_ukf_state_t *s = state;
    uint8_t bad = ev_model_configure(&s->model, mode, params, own_ranges, N_OWN);
    if (bad != 0u) {
        return bad;
    }
    const uint8_t *own = params + 4u * EV_N_PARAMS;
    s->p0_f = get_f32(own + 4u * EV_PF_P0F);
    s->q_f = get_f32(own + 4u * EV_PF_QF);
    float a = get_f32(own + 4u * P_ALPHA);
    float n = (float)EV_NX, lam = a * a * n - n; /* (42), κ = 0 */
    s->spread = sqrtf(n + lam);
    s->wm0 = lam / (n + lam);
    s->wc0 = s->wm0 + 1.0f - a * a + 2.0f;
    s->w1 = 0.5f / (n + lam);
    ev_ukf_reset(s);
    return 0;
}

/* χ = x, x ± spread · columns of chol(P); 0 if P is not positive definite. */
static uint8_t sigma_points(ev_ukf_state_t *s)
{
    float L[EV_NX * EV_NX];
    if (!chol_factor_f32(s->P, EV_NX, L)) {
        return 0;
    }
    for (uint8_t j = 0; j < EV_NX; j++) {
        for (uint8_t i = 0; i < EV_NX; i++) {
            float d = s->spread * L[i * EV_NX + j];
            s->chi[1u + j][i] = s->x[i] + d;
            s->chi[1u + EV_NX + j][i] = s->x[i] - d;
        }
    }
    memcpy(s->chi[0], s->x, sizeof s->chi[0]);
    return 1;
}

/* Σ W_j v_j as v_0 + w1 Σ_{j>0} (v_j - v_0): the weights sum to one. */
static void mean(const ev_ukf_state_t *s, const float (*v)[EV_NX], float *out)
{
    for (uint8_t i = 0; i < EV_NX; i++) {
        float acc = 0.0f;
        for (uint8_t j = 1; j < EV_UKF_NS; j++) {
            acc += v[j][i] - v[0][i];
        }
        out[i] = v[0][i] + s->w1 * acc;
    }
}

/* out = Σ W_j (EV_NY == EV_NX, so one row type serves states and measurements):
 * (a_j - ma)(b_j - mb)ᵀ with W^(c). */
static void cov(const ev_ukf_state_t *s, const float (*a)[EV_NX], const float *ma,
                const float (*b)[EV_NX], const float *mb, float *out)
{
    for (uint8_t i = 0; i < EV_NX; i++) {
        for (uint8_t k = 0; k < EV_NX; k++) {
            float acc = 0.0f;
            for (uint8_t j = 1; j < EV_UKF_NS; j++) {
                acc += (a[j][i] - ma[i]) * (b[j][k] - mb[k]);
            }
            out[i * EV_NX + k] = s->wc0 * (a[0][i] - ma[i]) * (b[0][k] - mb[k]) + s->w1 * acc;
        }
    }
}

static uint8_t predict(ev_ukf_state_t *s)
{
    if (!sigma_points(s)) {
        return STATUS_SINGULAR;
    }
    for (uint8_t j = 0; j < EV_UKF_NS; j++) {
        ev_wheels_t w;
        ev_wheels(s->chi[j], &s->u_prev, &s->model, &w);
        ev_step(&s->model, s->chi[j], &s->u_prev, &w);
    }
    mean(s, (const float (*)[EV_NX])s->chi, s->x);
    cov(s, (const float (*)[EV_NX])s->chi, s->x, (const float (*)[EV_NX])s->chi, s->x, s->P);
    const float *p = s->model.p;
    const float q[3] = {p[EV_P_QV], p[EV_P_QVY], p[EV_P_QR]};
    for (uint8_t i = 0; i < EV_NX; i++) {
        s->P[i * EV_NX + i] += i < 3u ? q[i] : s->q_f;
    }
    return 0;
}

static uint8_t update(ev_ukf_state_t *s, const ev_inputs_t *u)
{
    float r[EV_NY], y[EV_NY];
    ev_wheels_t w;
    ev_wheels(s->x, u, &s->model, &w);
    ev_noise(&s->model, u, &w, r);
    if (!sigma_points(s)) {
        return STATUS_SINGULAR;
    }
    for (uint8_t j = 0; j < EV_UKF_NS; j++) {
        ev_wheels(s->chi[j], u, &s->model, &w);
        ev_h(&s->model, s->chi[j], s->chi[j] + 3, u, &w, s->Y[j]);
    }
    mean(s, (const float (*)[EV_NX])s->Y, y);
    cov(s, (const float (*)[EV_NX])s->Y, y, (const float (*)[EV_NX])s->Y, y, s->S);
    for (uint8_t i = 0; i < EV_NY; i++) {
        s->S[i * EV_NY + i] += r[i];
    }
    cov(s, (const float (*)[EV_NX])s->chi, s->x, (const float (*)[EV_NX])s->Y, y, s->C);
    if (!chol_inv_f32(s->S, EV_NY)) {
        return STATUS_SINGULAR;
    }
    /* K = P_xy P_yy⁻¹; x += K (y - ŷ); P -= K P_yy Kᵀ = K P_xyᵀ. */
    float K[EV_NX * EV_NY], e[EV_NY];
    for (uint8_t i = 0; i < EV_NY; i++) {
        e[i] = u->y[i] - y[i];
    }
    for (uint8_t i = 0; i < EV_NX; i++) {
        for (uint8_t k = 0; k < EV_NY; k++) {
            float acc = 0.0f;
            for (uint8_t j = 0; j < EV_NY; j++) {
                acc += s->C[i * EV_NY + j] * s->S[j * EV_NY + k];
            }
            K[i * EV_NY + k] = acc;
        }
    }
    for (uint8_t i = 0; i < EV_NX; i++) {
        float dx = 0.0f;
        for (uint8_t k = 0; k < EV_NY; k++) {
            dx += K[i * EV_NY + k] * e[k];
        }
        s->x[i] += dx;
        for (uint8_t c = 0; c < EV_NX; c++) {
            float acc = 0.0f;
            for (uint8_t k = 0; k < EV_NY; k++) {
                acc += K[i * EV_NY + k] * s->C[c * EV_NY + k];
            }
            s->P[i * EV_NX + c] -= acc;
        }
    }
    return 0;
}

/* A P that lost definiteness to round-off keeps only its diagonal (as the host does). */
static void diagonal_only(float *P)
{
    for (uint8_t i = 0; i < EV_NX; i++) {
        for (uint8_t j = 0; j < EV_NX; j++) {
            if (i != j) {
                P[i * EV_NX + j] = 0.0f;
            }
        }
    }
}

static uint8_t ev_ukf_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                           uint8_t *out_len)
{
    (void)in_len;
    ev_ukf_state_t *s = state;
    ev_inputs_t u;
    *out_len = 4u * EV_N_OUTPUTS;
    uint8_t status = ev_model_inputs(&s->model, in, &u);
    if (status == 0u) {
        if (s->started && predict(s) != 0u) {
            status |= STATUS_SINGULAR;
            diagonal_only(s->P);
        }
        if (update(s, &u) != 0u) {
            status |= STATUS_SINGULAR;
            diagonal_only(s->P);
        }
        ev_symmetrize(s->P, EV_NX);
        s->u_prev = u;
        s->started = 1;
    }
    return (uint8_t)(status | ev_outputs(s->x, s->x + 3, out));
}

const ROM estimator_t ev_ukf_estimator = {
    .id = EV_UKF_ID,
    .name = "ev_ukf",
    .modes = 1u << MODE_F32,
    .n_inputs = EV_N_INPUTS,
    .n_outputs = EV_N_OUTPUTS,
    .n_params = EV_N_PARAMS + N_OWN,
    .configure = ev_ukf_configure,
    .reset = ev_ukf_reset,
    .step = ev_ukf_step,
};
