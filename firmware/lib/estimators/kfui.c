#include "estimators/kfui.h"

#include <math.h>
#include <string.h>

#include "estimators/health.h"
#include "proto/wire.h"

enum { P_T, P_Q, P_RX, P_RA, P_P0, P_S0, P_NISMAX, P_NISWIN, P_XMAX, P_HOLD, N_OWN };
#define N_PARAMS (N_OWN + SUSP_ECU_N_PARAMS)

static const ROM param_range_t ranges[N_OWN] = {
    {1e-4f, 0.05f, 30}, {1e-9f, 1e3f, 16}, {1e-9f, 1e3f, 16},
    {1e-9f, 1e3f, 16},  {0.0f, 1e3f, 16}, {0.0f, 1e3f, 16},
    {0.1f, 1e6f, 16},   {0.05f, 100.0f, 16}, {0.01f, 10.0f, 16},
    {0.0f, 1.0f, 16},
};

/* The rate the damper acts at: with damper_hold the literal square keeps its peak
 * compression force past dv_min = -c1 / 2c2 (docs/estimators/kfui.md, "Float32 against
 * float64"); dv_min is -inf without it. */
static float held(const kfui_state_t *s, float dv)
{
    return dv < s->c.dv_min ? s->c.dv_min : dv;
}

/* The strut's tangent stiffness k and damping c at deflection dx, rate dv (eq. 37). */
static void strut_slopes(const kfui_state_t *s, float dx, float dv, float *k, float *c)
{
    *k = s->ecu.model.k1 + dx * (s->c.k2_2 + s->c.k3_3 * dx);
    *c = s->ecu.model.c1 + s->c.c2_2 * held(s, dv);
}

/* ẍ_s and ẍ_us of the nominal model with the force u and the road input d (eqs. 4-5, 34). */
static void accelerations(const kfui_state_t *s, const float *x, float u, float d, float *a)
{
    const qcar_f32_t *m = &s->ecu.model;
    float strut = qcar_strut_f32(m, x[0] - x[2], held(s, x[1] - x[3]), 0);
    a[0] = (u - strut) * s->c.inv_m_s;
    a[1] = (strut - m->k_us * (x[2] - d) - u) * s->c.inv_m_us;
}

/* Row i of F v, F = I + T J: J's rows are e2ᵀ, -ρᵀ/m_s, e4ᵀ, ρᵀ/m_us - (k_us/m_us) e3ᵀ with
 * ρ = [k, c, -k, -c] (eq. 37); w = ρ·v. */
static float f_row(const kfui_state_t *s, const float *v, float w, uint8_t i)
{
    switch (i) {
    case 0:
        return v[0] + s->T * v[1];
    case 1:
        return v[1] - s->c.T_m_s * w;
    case 2:
        return v[2] + s->T * v[3];
    default:
        return v[3] + s->c.T_m_us * w - s->c.T_d1 * v[2];
    }
}

/* (27)-(28): x̄ = x + T f(x, u, û), P̄ = F P Fᵀ + Q: A = F P column by column (P is
 * symmetric, so its rows are its columns), then P̄ = F Aᵀ on the upper triangle. */
static void predict(kfui_state_t *s, float u, float *xb, float Pb[4][4])
{
    float T = s->T, a[2], k, c, A[4][4];
    accelerations(s, s->x, u, s->d, a);
    strut_slopes(s, s->x[0] - s->x[2], s->x[1] - s->x[3], &k, &c);
    xb[0] = s->x[0] + T * s->x[1];
    xb[1] = s->x[1] + T * a[0];
    xb[2] = s->x[2] + T * s->x[3];
    xb[3] = s->x[3] + T * a[1];
    for (uint8_t j = 0; j < 4u; j++) {
        const float *p = s->P[j];
        float w = k * (p[0] - p[2]) + c * (p[1] - p[3]);
        for (uint8_t i = 0; i < 4u; i++) {
            A[i][j] = f_row(s, p, w, i);
        }
    }
    for (uint8_t i = 0; i < 4u; i++) {
        const float *r = A[i];
        float w = k * (r[0] - r[2]) + c * (r[1] - r[3]);
        for (uint8_t j = 0; j <= i; j++) {
            Pb[i][j] = Pb[j][i] = f_row(s, r, w, j);
        }
        Pb[i][i] += s->q;
    }
}

/* (29)-(33) through Σ = H P̄ Hᵀ + R = L D Lᵀ (L unit lower triangular). With z = L⁻¹ r0
 * the decorrelated innovations, the GLS input estimate (30)-(31) is û = z_4 / d1 and the
 * update (32)-(33) is that of z_1..z_3 alone: x = x̄ + Σ_j Y_j z_j / D_j and
 * P = P̄ - Σ_j Y_j Y_jᵀ / D_j, j < 4, Y = P̄ Hᵀ L⁻ᵀ (docs/estimators/kfui.md). Σ_j z_j² / D_j,
 * j < 4, is the innovation's NIS outside the road's direction, into the health check's
 * average; û's variance S is D_4 / d1². */
static uint8_t update(kfui_state_t *s, const float *y, float u, const float *xb, float Pb[4][4])
{
    const kfui_const_t *c = &s->c;
    float a[2], k, cd, G[4][4], S[4][4];
    accelerations(s, xb, u, 0.0f, a);
    strut_slopes(s, xb[0] - xb[2], xb[1] - xb[3], &k, &cd);
    for (uint8_t i = 0; i < 4u; i++) { /* G = P̄ Hᵀ */
        const float *p = Pb[i];
        float w = k * (p[0] - p[2]) + cd * (p[1] - p[3]);
        G[i][0] = p[0];
        G[i][1] = -c->inv_m_s * w;
        G[i][2] = p[2];
        G[i][3] = c->inv_m_us * w - c->d1 * p[2];
    }
    /* Σ = H G, lower triangle: an entry with a displacement row is an entry of G. */
    float t1 = k * (G[0][1] - G[2][1]) + cd * (G[1][1] - G[3][1]);
    float t3 = k * (G[0][3] - G[2][3]) + cd * (G[1][3] - G[3][3]);
    S[0][0] = G[0][0] + s->r_x;
    S[1][0] = G[0][1];
    S[1][1] = s->r_a - c->inv_m_s * t1;
    S[2][0] = G[0][2];
    S[2][1] = G[2][1];
    S[2][2] = G[2][2] + s->r_x;
    S[3][0] = G[0][3];
    S[3][1] = c->inv_m_us * t1 - c->d1 * G[2][1];
    S[3][2] = G[2][3];
    S[3][3] = s->r_a + c->inv_m_us * t3 - c->d1 * G[2][3];
    float L[4][4], E[4][4], inv_D[4], pivot = 0.0f; /* E_ij = L_ij D_j; pivot: D_4 */
    for (uint8_t j = 0; j < 4u; j++) {
        for (uint8_t i = j; i < 4u; i++) {
            float v = S[i][j];
            for (uint8_t m = 0; m < j; m++) {
                v -= L[i][m] * E[j][m];
            }
            if (i == j) {
                if (!(v > 0.0f)) {
                    memcpy(s->x, xb, sizeof s->x);
                    memcpy(s->P, Pb, sizeof s->P);
                    return STATUS_SINGULAR;
                }
                inv_D[j] = 1.0f / v;
                pivot = v;
            } else {
                E[i][j] = v;
                L[i][j] = v * inv_D[j];
            }
        }
    }
    float r0[4] = {y[0] - xb[0], y[1] - a[0], y[2] - xb[2], y[3] - a[1]}; /* y - h(x̄, u, 0) */
    float z[4];
    for (uint8_t i = 0; i < 4u; i++) {
        float v = r0[i];
        for (uint8_t m = 0; m < i; m++) {
            v -= L[i][m] * z[m];
        }
        z[i] = v;
    }
    s->d = z[3] * c->inv_d1;
    s->var_d = pivot * c->inv_d1 * c->inv_d1;
    s->nis = health_window_mean(s->nis, s->alpha,
                             z[0] * z[0] * inv_D[0] + z[1] * z[1] * inv_D[1] + z[2] * z[2] * inv_D[2]);
    float Y[4][3], V[4][3];
    for (uint8_t i = 0; i < 4u; i++) {
        for (uint8_t j = 0; j < 3u; j++) {
            float v = G[i][j];
            for (uint8_t m = 0; m < j; m++) {
                v -= L[j][m] * Y[i][m];
            }
            Y[i][j] = v;
            V[i][j] = v * inv_D[j];
        }
        s->x[i] = xb[i] + V[i][0] * z[0] + V[i][1] * z[1] + V[i][2] * z[2];
    }
    for (uint8_t i = 0; i < 4u; i++) {
        for (uint8_t j = i; j < 4u; j++) {
            s->P[i][j] = s->P[j][i] =
                Pb[i][j] - V[i][0] * Y[j][0] - V[i][1] * Y[j][1] - V[i][2] * Y[j][2];
        }
    }
    return 0;
}

/* DIVERGED (docs/estimators/kfui.md, "Health"): the windowed NIS passes nis_max, a variance
 * is negative, or x̂_s, x̂_us or û is 3σ outside ±x_max. */
static uint8_t healthy(const kfui_state_t *s)
{
    float x_max = s->x_max;
    return s->nis <= s->nis_max && s->P[0][0] >= 0.0f && s->P[1][1] >= 0.0f &&
           s->P[2][2] >= 0.0f && s->P[3][3] >= 0.0f && s->var_d >= 0.0f &&
           !health_outside_3sigma(s->x[0], -x_max, x_max, s->P[0][0]) &&
           !health_outside_3sigma(s->x[2], -x_max, x_max, s->P[2][2]) &&
           !health_outside_3sigma(s->d, -x_max, x_max, s->var_d);
}

static uint8_t kfui_update(kfui_state_t *s, const float *y, float u)
{
    float xb[4], Pb[4][4];
    predict(s, u, xb, Pb);
    uint8_t status = update(s, y, u, xb, Pb);
    return healthy(s) ? status : status | STATUS_DIVERGED;
}

static uint8_t kfui_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                         uint8_t *out_len)
{
    kfui_state_t *s = state;
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
    accelerations(s, s->x, 0.0f, s->d, a);
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
        s->P[i][i] = s->p0;
    }
    s->d = 0.0f; /* û*(0) = 0; S is recomputed each step, so S0 is never read (30) */
    s->var_d = 0.0f;
    s->nis = 0.0f;
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
    s->r_x = get_f32(params + 4u * P_RX);
    s->r_a = get_f32(params + 4u * P_RA);
    s->p0 = get_f32(params + 4u * P_P0);
    s->nis_max = get_f32(params + 4u * P_NISMAX);
    s->alpha = s->T / get_f32(params + 4u * P_NISWIN);
    s->x_max = get_f32(params + 4u * P_XMAX);
    susp_ecu_configure_f32(&s->ecu, params, N_OWN, mode, s->T);
    const qcar_f32_t *m = &s->ecu.model;
    float inv_m_s = 1.0f / m->m_s, inv_m_us = 1.0f / m->m_us, d1 = m->k_us * inv_m_us;
    s->c = (kfui_const_t){
        .inv_m_s = inv_m_s,
        .inv_m_us = inv_m_us,
        .d1 = d1,
        .inv_d1 = m->m_us / m->k_us,
        .T_m_s = s->T * inv_m_s,
        .T_m_us = s->T * inv_m_us,
        .T_d1 = s->T * d1,
        .k2_2 = 2.0f * m->k2,
        .k3_3 = 3.0f * m->k3,
        .c2_2 = 2.0f * m->c2,
        .dv_min = get_f32(params + 4u * P_HOLD) >= 0.5f && m->c2 > 0.0f
                      ? -m->c1 / (2.0f * m->c2)
                      : -INFINITY,
    };
    kfui_reset(s);
    return 0;
}

const ROM estimator_t kfui_estimator = {
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
