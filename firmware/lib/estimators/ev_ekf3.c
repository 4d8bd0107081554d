#include "estimators/ev_ekf3.h"

#include <string.h>

#include "linalg/mat_f32.h"

static void ev_ekf3_reset(void *state)
{
    ev_ekf3_state_t *s = state;
    ev_model_reset(&s->model);
    ev_prior(&s->model, 3, 0.0f, s->x, s->P);
    memset(s->fy, 0, sizeof s->fy);
    s->started = 0;
}

static const ROM param_range_t own_ranges[] = {{0.0f, 1.0f, 16}}; /* tires: 0 MF, 1 linear */

static uint8_t ev_ekf3_configure(void *state, uint8_t mode, const uint8_t *params)
{
    ev_ekf3_state_t *s = state;
    uint8_t bad = ev_model_configure(&s->model, mode, params, own_ranges, 1);
    if (bad != 0u) {
        return bad;
    }
    s->model.linear = param_value(params, EV_N_PARAMS, mode, param_range_q(own_ranges, 0)) >= 0.5f;
    ev_ekf3_reset(s);
    return 0;
}

/* The inverse of a symmetric 3×3 (upper triangle a b c / d e / f) by its adjugate, into
 * out (full). */
static void inverse3(const float *S, float *out)
{
    float a = S[0], b = S[1], c = S[2], d = S[4], e = S[5], f = S[8];
    float A00 = d * f - e * e, A01 = c * e - b * f, A02 = b * e - c * d;
    float inv = 1.0f / (a * A00 + b * A01 + c * A02);
    out[0] = A00 * inv;
    out[1] = out[3] = A01 * inv;
    out[2] = out[6] = A02 * inv;
    out[4] = (a * f - c * c) * inv;
    out[5] = out[7] = (b * c - a * e) * inv;
    out[8] = (a * d - b * b) * inv;
}

/* The batch update in information form, P⁺ = (P⁻¹ + Hᵀ R⁻¹ H)⁻¹ and x⁺ = x + P⁺ Hᵀ R⁻¹ e:
 * with 3 states and 7 measurements two 3×3 inverses cost half of 7 scalar updates.
 * H's row of γ is [0 0 1]. The correction x⁺ - x into dx. */
static void correct(float *x, float *P, const float *H, const float *e, const float *r,
                    float *dx)
{
    float Y[9], g[3] = {0.0f, 0.0f, 0.0f};
    inverse3(P, Y);
    for (uint8_t j = 0; j < EV_NY; j++) {
        const float *h = H + 3u * j;
        float ir = 1.0f / r[j];
        if (j == 2u) {
            Y[8] += ir;
            g[2] += e[j] * ir;
            continue;
        }
        float w[3] = {h[0] * ir, h[1] * ir, h[2] * ir};
        for (uint8_t a = 0; a < 3u; a++) {
            g[a] += w[a] * e[j];
            for (uint8_t b = a; b < 3u; b++) {
                Y[a * 3u + b] += w[a] * h[b];
            }
        }
    }
    inverse3(Y, P);
    for (uint8_t a = 0; a < 3u; a++) {
        dx[a] = P[a * 3u] * g[0] + P[a * 3u + 1u] * g[1] + P[a * 3u + 2u] * g[2];
        x[a] += dx[a];
    }
}

static void predict(ev_ekf3_state_t *s)
{
    const float *p = s->model.p;
    float F[9], FP[9], rates[3];
    /* No tire evaluation here: the forces at x_{k-1|k-1} are the last update's, carried
     * there to first order, and their slopes (so J) are that update's (same u_{k-1}). */
    ev_f3(&s->model, s->x, s->J, F);
    ev_body_rates(&s->model, s->x, s->fy, &s->dr_prev, rates);
    for (uint8_t i = 0; i < 3u; i++) {
        s->x[i] += s->model.T * rates[i];
    }
    mat_mul_f32(F, s->P, 3, 3, 3, FP);
    /* F P Fᵀ is symmetric: its upper triangle, mirrored */
    for (uint8_t i = 0; i < 3u; i++) {
        for (uint8_t j = i; j < 3u; j++) {
            float acc = 0.0f;
            for (uint8_t k = 0; k < 3u; k++) {
                acc += FP[i * 3u + k] * F[j * 3u + k];
            }
            s->P[i * 3u + j] = s->P[j * 3u + i] = acc;
        }
    }
    s->P[0] += p[EV_P_QV];
    s->P[4] += p[EV_P_QVY];
    s->P[8] += p[EV_P_QR];
}

static void update(ev_ekf3_state_t *s, const ev_inputs_t *u)
{
    float r[EV_NY], e[EV_NY], H[EV_NY * 3u], dx[3];
    const ev_slopes_t *d = &s->d;
    ev_wheels_t w;
    ev_wheels(s->x, u, &s->model, &w);
    ev_slopes(u, &s->model, &w, &s->d);
    ev_noise(&s->model, u, &w, r);
    ev_force_slopes3(&s->model, u, d, s->J);
    ev_h3(&s->model, s->x, u, &w, d, s->J, H);
    ev_h(&s->model, s->x, w.fy_qs, u, &w, e);
    for (uint8_t j = 0; j < EV_NY; j++) {
        e[j] = u->y[j] - e[j];
    }
    correct(s->x, s->P, H, e, r, dx);
    /* the forces at the corrected state, to first order: a third tire evaluation would
     * cost as much as the rest of the update */
    for (uint8_t i = 0; i < 4u; i++) {
        const float *da = d->dalpha[i];
        s->fy[i] = w.fy_qs[i] + d->dqs[i] * (da[0] * dx[0] + da[1] * dx[1] + da[2] * dx[2]);
    }
}

static uint8_t ev_ekf3_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                            uint8_t *out_len)
{
    (void)in_len;
    ev_ekf3_state_t *s = state;
    ev_inputs_t u;
    *out_len = 4u * EV_N_OUTPUTS;
    uint8_t status = ev_model_inputs(&s->model, in, &u);
    if (status == 0u) {
        if (s->started) {
            predict(s);
        }
        update(s, &u); /* P stays exactly symmetric: no ev_symmetrize */
        s->dr_prev = u.dr;
        s->started = 1;
    }
    return (uint8_t)(status | ev_outputs(s->x, s->fy, out));
}

const ROM estimator_t ev_ekf3_estimator = {
    .id = EV_EKF3_ID,
    .name = "ev_ekf3",
    .modes = 1u << MODE_F32,
    .n_inputs = EV_N_INPUTS,
    .n_outputs = EV_N_OUTPUTS,
    .n_params = EV_N_PARAMS + 1u, /* and tires */
    .configure = ev_ekf3_configure,
    .reset = ev_ekf3_reset,
    .step = ev_ekf3_step,
};
