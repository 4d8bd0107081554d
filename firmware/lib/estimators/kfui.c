#include "estimators/kfui.h"

#include <math.h>
#include <string.h>

#include "linalg/chol_f32.h"
#include "linalg/mat_f32.h"
#include "proto/wire.h"

enum { P_T, P_INTEGRATOR, P_Q, P_RX, P_RA, P_P0, P_S0, N_OWN };
#define N_PARAMS (N_OWN + SUSP_ECU_N_PARAMS)

static const param_range_t ranges[N_OWN] = {
    {1e-4f, 0.05f, 30}, {0.0f, 0.0f, 0}, {1e-9f, 1e3f, 16}, {1e-9f, 1e3f, 16},
    {1e-9f, 1e3f, 16},  {0.0f, 1e3f, 16}, {0.0f, 1e3f, 16},
};

/* ẍ_s and ẍ_us of the nominal model with the road input d (eqs. 4-5, 34). */
static void accelerations(const qcar_f32_t *m, const float *x, float u, float d, float *a)
{
    float strut = qcar_strut_f32(m, x[0] - x[2], x[1] - x[3], 0);
    a[0] = (u - strut) / m->m_s;
    a[1] = (strut - m->k_us * (x[2] - d) - u) / m->m_us;
}

/* Rows 2 and 4 of the Jacobian (eq. 37) at x; rows 1 and 3 are [0 1 0 0], [0 0 0 1]. */
static void jacobian_rows(const qcar_f32_t *m, const float *x, float *row2, float *row4)
{
    float dx = x[0] - x[2];
    float ks = m->k1 + 2.0f * m->k2 * dx + 3.0f * m->k3 * dx * dx;
    float cs = m->c1 + 2.0f * m->c2 * (x[1] - x[3]);
    const float r[4] = {ks, cs, -ks, -cs};
    for (uint8_t j = 0; j < 4u; j++) {
        row2[j] = -r[j] / m->m_s;
        row4[j] = r[j] / m->m_us;
    }
    row4[2] -= m->k_us / m->m_us;
}

static uint8_t kfui_update(kfui_state_t *s, const float *y, float u)
{
    const qcar_f32_t *m = &s->ecu.model;
    float a[2], *F = s->H, *tmp = s->K;
    /* (27)-(28): x̄ = x + T f(x, u, û), F = I + T J, P̄ = F P Fᵀ + Q */
    memset(F, 0, 16 * sizeof(float));
    jacobian_rows(m, s->x, F + 4, F + 12);
    F[1] = F[11] = 1.0f;
    for (uint8_t i = 0; i < 16u; i++) {
        F[i] = (i % 5u == 0u ? 1.0f : 0.0f) + s->T * F[i];
    }
    accelerations(m, s->x, u, s->d, a);
    float xb[4] = {s->x[0] + s->T * s->x[1], s->x[1] + s->T * a[0], s->x[2] + s->T * s->x[3],
                   s->x[3] + s->T * a[1]};
    mat_mul_f32(F, s->P, 4, 4, 4, tmp);
    mat_mul_bt_f32(tmp, F, 4, 4, 4, s->Pb);
    for (uint8_t i = 0; i < 4u; i++) {
        s->Pb[5u * i] += s->q;
    }
    /* (29): H at x̄, Σ = H P̄ Hᵀ + R, K = P̄ Hᵀ Σ⁻¹ */
    float *H = s->H;
    memset(H, 0, 16 * sizeof(float));
    H[0] = H[10] = 1.0f;
    jacobian_rows(m, xb, H + 4, H + 12);
    mat_mul_bt_f32(s->Pb, H, 4, 4, 4, s->PHt);
    mat_mul_f32(H, s->PHt, 4, 4, 4, s->Sig);
    for (uint8_t i = 0; i < 4u; i++) {
        s->Sig[5u * i] += s->r[i];
    }
    if (!chol_inv_f32(s->Sig, 4)) {
        memcpy(s->x, xb, sizeof xb);
        memcpy(s->P, s->Pb, sizeof s->P);
        return STATUS_SINGULAR;
    }
    mat_mul_f32(s->PHt, s->Sig, 4, 4, 4, s->K);
    /* (30)-(31) with R⁻¹(I - HK) = Σ⁻¹ and D = [0 0 0 d1]: r0 = y - h(x̄, u, 0) */
    accelerations(m, xb, u, 0.0f, a);
    float r0[4] = {y[0] - xb[0], y[1] - a[0], y[2] - xb[2], y[3] - a[1]};
    float d1 = m->k_us / m->m_us, w3 = 0.0f;
    for (uint8_t j = 0; j < 4u; j++) {
        w3 += s->Sig[12u + j] * r0[j];
    }
    float S = 1.0f / (d1 * d1 * s->Sig[15]);
    s->d = S * d1 * w3;
    r0[3] -= d1 * s->d;
    /* (32): x = x̄ + K (r0 - D û) */
    for (uint8_t i = 0; i < 4u; i++) {
        float dx = 0.0f;
        for (uint8_t j = 0; j < 4u; j++) {
            dx += s->K[4u * i + j] * r0[j];
        }
        s->x[i] = xb[i] + dx;
    }
    /* (33) = P̄ - K (H P̄) + S (K D)(K D)ᵀ, with H P̄ = PHtᵀ; kept symmetric (float32) */
    for (uint8_t i = 0; i < 4u; i++) {
        for (uint8_t j = 0; j <= i; j++) {
            float khp = 0.0f;
            for (uint8_t k = 0; k < 4u; k++) {
                khp += 0.5f * (s->K[4u * i + k] * s->PHt[4u * j + k] +
                               s->K[4u * j + k] * s->PHt[4u * i + k]);
            }
            float p = s->Pb[4u * i + j] - khp + S * d1 * d1 * s->K[4u * i + 3u] * s->K[4u * j + 3u];
            s->P[4u * i + j] = s->P[4u * j + i] = p;
        }
    }
    return 0;
}

static uint8_t kfui_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                         uint8_t *out_len)
{
    kfui_state_t *s = state;
    const qcar_f32_t *m = &s->ecu.model;
    (void)in_len;
    *out_len = 4u * SUSP_ECU_N_OUTPUTS;
    float a_s = get_f32(in), a_us = get_f32(in + 4);
    uint8_t status = 0;
    if (!isfinite(a_s) || !isfinite(a_us)) {
        status = STATUS_NOT_FINITE;
    } else {
        float y[4] = {accel_cond_step_f32(&s->ecu.cond, &s->ecu.ch[0], a_s), a_s,
                      accel_cond_step_f32(&s->ecu.cond, &s->ecu.ch[1], a_us), a_us};
        status = kfui_update(s, y, s->ecu.u);
        if (!isfinite(s->x[0] + s->x[1] + s->x[2] + s->x[3] + s->d)) {
            status |= STATUS_NOT_FINITE;
        }
    }
    float a[2];
    accelerations(m, s->x, 0.0f, s->d, a);
    susp_est_f32_t est = {s->x[0], s->x[1], s->x[2], s->x[3], a[0], a[1], s->d};
    if (!(status & STATUS_NOT_FINITE)) {
        s->ecu.u = susp_ctrl_step_f32(&s->ecu.ctrl, &est, &status);
    }
    susp_ecu_put_f32(out, &est, s->ecu.u);
    return status;
}

static void kfui_reset(void *state)
{
    kfui_state_t *s = state;
    susp_ecu_reset_f32(&s->ecu);
    memset(s->x, 0, sizeof s->x);
    memset(s->P, 0, sizeof s->P);
    for (uint8_t i = 0; i < 4u; i++) {
        s->P[5u * i] = s->p0;
    }
    s->d = 0.0f; /* û*(0) = 0; S is recomputed each step, so S0 is never read (30) */
}

static uint8_t kfui_configure(void *state, uint8_t mode, const uint8_t *params)
{
    kfui_state_t *s = state;
    uint8_t bad = susp_ecu_check(params, mode, ranges, N_OWN);
    if (bad != 0) {
        return bad;
    }
    s->T = get_f32(params + 4u * P_T);
    s->q = get_f32(params + 4u * P_Q);
    float r_x = get_f32(params + 4u * P_RX), r_a = get_f32(params + 4u * P_RA);
    s->r[0] = s->r[2] = r_x;
    s->r[1] = s->r[3] = r_a;
    s->p0 = get_f32(params + 4u * P_P0);
    susp_ecu_configure_f32(&s->ecu, params, N_OWN, mode, s->T);
    kfui_reset(s);
    return 0;
}

const estimator_t kfui_estimator = {
    .id = KFUI_ID,
    .name = "kfui",
    .modes = 1u << MODE_F32,
    .n_inputs = 2,
    .n_outputs = SUSP_ECU_N_OUTPUTS,
    .n_params = N_PARAMS,
    .configure = kfui_configure,
    .reset = kfui_reset,
    .step = kfui_step,
};
