#include "estimators/uiiekf.h"

#include <math.h>
#include <string.h>

#include "estimators/params.h"
#include "linalg/mat_f32.h"
#include "proto/wire.h"

enum { P_T, P_N, P_ITER, P_FORM, P_SURF, P_P0, P_QV, P_QLAT, P_QW, P_R, N_PARAMS };

static const param_range_t ranges[N_PARAMS] = {
    {1e-4f, 0.1f, 0}, {3.0f, 5.0f, 0},   {1.0f, 10.0f, 0}, {0.0f, 1.0f, 0},   {0.0f, 6.0f, 0},
    {1e-6f, 1e3f, 0}, {0.0f, 10.0f, 0},  {0.0f, 10.0f, 0}, {0.0f, 100.0f, 0}, {1e-6f, 100.0f, 0},
};

/* Table 2 (Pride) and the Burckhardt surfaces of note §1.5, as in plants/braking.py. */
#define M_VEH 850.0f
#define R_W 0.27f
#define I_W 4.15f
#define PSI 0.85f
#define H_CG 0.57f
#define W_VEH 8330.0f
#define RHO 1.027f
#define L_R 1.425f
#define L_F 0.92f
#define I_Z 1627.0f
#define K_B 0.7f
#define C_D 0.32f
#define H_A 1.16f
#define A_F 1.87f
#define L_WB (L_F + L_R)

static const float surfaces[7][3] = {
    {1.2801f, 23.99f, 0.52f},   {0.857f, 33.822f, 0.347f},  {1.1973f, 25.168f, 0.5373f},
    {1.3713f, 6.4565f, 0.6691f}, {0.4004f, 33.708f, 0.1204f}, {0.1946f, 94.129f, 0.0646f},
    {0.05f, 306.39f, 0.0f},
};

static float mu_over_slip(float slip, const float *c)
{
    if (slip < 1e-6f) {
        return PSI * (c[0] * c[1] - c[2]);
    }
    return PSI * (c[0] * (1.0f - expf(-c[1] * slip)) - c[2] * slip) / slip;
}

/* ẋ of eqs. 2-16, consistent reading, δ = 0 and no brake torque (the unknown input). */
static void derivatives(const float *tire, const float *x, float d_x, float *dx)
{
    float v_x = x[0] > 0.1f ? x[0] : 0.1f, v_y = x[1], r = x[2];
    float drag = 0.5f * RHO * C_D * A_F * v_x * v_x * H_A / (2.0f * L_WB);
    float transfer = M_VEH * d_x * H_CG / (2.0f * L_WB);
    float f_z[2] = {W_VEH * L_R / (2.0f * L_WB) - transfer - drag,
                    W_VEH * L_F / (2.0f * L_WB) + transfer + drag};
    float f_x[2], f_y[2];
    for (uint8_t i = 0; i < 2u; i++) {
        float lever = i == 0u ? L_F : -L_R;
        float w = x[3u + i];
        float v_lat = v_y + lever * r;
        float v_w = sqrtf(v_lat * v_lat + v_x * v_x);
        float alpha = -atan2f(v_lat, v_x);
        float s_x = (v_w - R_W * w * cosf(alpha)) / v_w; /* braking positive */
        float s_y = R_W * w * sinf(alpha) / v_w;
        float k = mu_over_slip(sqrtf(s_x * s_x + s_y * s_y), tire) * (f_z[i] > 0.0f ? f_z[i] : 0.0f);
        f_x[i] = k * s_x;
        f_y[i] = k * s_y;
    }
    dx[0] = 2.0f * (-f_x[0] - f_x[1]) / M_VEH + r * v_y;
    dx[1] = 2.0f * (f_y[0] + f_y[1]) / M_VEH - r * v_x;
    dx[2] = 2.0f * (L_F * f_y[0] - L_R * f_y[1]) / I_Z;
    dx[3] = R_W * f_x[0] / I_W;
    dx[4] = R_W * f_x[1] / I_W;
}

/* ẋ in the filter's own states (all five, or v_x, ω_f, ω_r). */
static void xdot(const uiiekf_state_t *st, const float *x, float *dx)
{
    float full[5], d[5];
    if (st->p.n == 5u) {
        memcpy(full, x, sizeof full);
    } else {
        full[0] = x[0];
        full[1] = full[2] = 0.0f;
        full[3] = x[1];
        full[4] = x[2];
    }
    derivatives(st->p.tire, full, st->d_x, d);
    if (st->p.n == 5u) {
        memcpy(dx, d, sizeof d);
    } else {
        dx[0] = d[0];
        dx[1] = d[3];
        dx[2] = d[4];
    }
}

static void reset(uiiekf_state_t *st)
{
    uint8_t n = st->p.n;
    memset(st->x, 0, sizeof st->x);
    memset(st->P, 0, sizeof st->P);
    for (uint8_t i = 0; i < n; i++) {
        st->P[i * n + i] = st->p.p0;
    }
    st->d_x = 0.0f;
    st->started = 0;
}

/* One pass of eq. 36: L = K + (I - K C) B (Bᵀ Cᵀ F⁻¹ C B)⁻¹ Bᵀ Cᵀ F⁻¹, then x and P. */
static uint8_t measurement_update(uiiekf_state_t *st, const float *z, const float *cb)
{
    uint8_t n = st->p.n, a = (uint8_t)(n - 2u);
    float *P = st->P;
    float r = st->p.r_meas;
    float F[4] = {P[a * n + a] + r, P[a * n + a + 1u], P[(a + 1u) * n + a], P[(a + 1u) * n + a + 1u] + r};
    if (!mat_inv2_f32(F)) {
        return STATUS_SINGULAR;
    }
    float K[UIIEKF_MAX_STATES * 2], L[UIIEKF_MAX_STATES * 2];
    for (uint8_t i = 0; i < n; i++) { /* K = P Cᵀ F⁻¹: C picks the two wheel states */
        K[2 * i] = P[i * n + a] * F[0] + P[i * n + a + 1u] * F[2];
        K[2 * i + 1] = P[i * n + a] * F[1] + P[i * n + a + 1u] * F[3];
    }
    float w0 = cb[0] * F[0] + cb[1] * F[2], w1 = cb[0] * F[1] + cb[1] * F[3]; /* Bᵀ Cᵀ F⁻¹ */
    float g = w0 * cb[0] + w1 * cb[1];
    if (!(g > 1e-30f || g < -1e-30f)) {
        return STATUS_SINGULAR;
    }
    for (uint8_t i = 0; i < n; i++) {
        float b_i = i == a ? cb[0] : (i == a + 1u ? cb[1] : 0.0f); /* B's non-zero rows */
        float v = (b_i - (K[2 * i] * cb[0] + K[2 * i + 1] * cb[1])) / g; /* (I - K C) B / g */
        L[2 * i] = K[2 * i] + v * w0;
        L[2 * i + 1] = K[2 * i + 1] + v * w1;
    }
    float e0 = z[0] - st->x[a], e1 = z[1] - st->x[a + 1u];
    for (uint8_t i = 0; i < n; i++) {
        st->x[i] += L[2 * i] * e0 + L[2 * i + 1] * e1;
    }
    /* P = (I - L C) P (I - L C)ᵀ + r L Lᵀ, using C's two columns: M = P - L (C P). */
    float *M = st->tmp;
    for (uint8_t i = 0; i < n; i++) {
        for (uint8_t j = 0; j < n; j++) {
            M[i * n + j] = P[i * n + j] - L[2 * i] * P[a * n + j] - L[2 * i + 1] * P[(a + 1u) * n + j];
        }
    }
    for (uint8_t i = 0; i < n; i++) {
        for (uint8_t j = 0; j < n; j++) {
            P[i * n + j] = M[i * n + j] - M[i * n + a] * L[2 * j] - M[i * n + a + 1u] * L[2 * j + 1] +
                           r * (L[2 * i] * L[2 * j] + L[2 * i + 1] * L[2 * j + 1]);
        }
    }
    return 0;
}

static uint8_t uiiekf_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                           uint8_t *out_len)
{
    uiiekf_state_t *st = state;
    (void)in_len;
    *out_len = 8;
    uint8_t n = st->p.n, a = (uint8_t)(n - 2u);
    float z[2] = {get_f32(in), get_f32(in + 4)};
    uint8_t status = 0;
    float d_hat = 0.0f;
    if (!isfinite(z[0]) || !isfinite(z[1])) {
        status = STATUS_NOT_FINITE;
    } else {
        if (!st->started) {
            st->started = 1;
            st->x[0] = R_W * z[0]; /* v_x(0) = R ω_f(0) */
            st->x[a] = z[0];
            st->x[a + 1u] = z[1];
        }
        float cb[2] = {-K_B * st->p.T / I_W, -(1.0f - K_B) * st->p.T / I_W}; /* C B */
        float e0 = z[0] - st->x[a], e1 = z[1] - st->x[a + 1u];
        d_hat = (cb[0] * e0 + cb[1] * e1) / (cb[0] * cb[0] + cb[1] * cb[1]);
        uint8_t passes = st->p.form ? 1u : st->p.iterations;
        for (uint8_t i = 0; i < passes && status == 0; i++) {
            status |= measurement_update(st, z, cb);
        }
        /* Time update, eq. 37: J = I + T ∂ẋ/∂x by forward differences, P = J P Jᵀ + Q. */
        float dx[UIIEKF_MAX_STATES], dxh[UIIEKF_MAX_STATES], xh[UIIEKF_MAX_STATES];
        xdot(st, st->x, dx);
        for (uint8_t j = 0; j < n; j++) {
            memcpy(xh, st->x, sizeof xh);
            float h = 1e-3f * (fabsf(st->x[j]) > 1.0f ? fabsf(st->x[j]) : 1.0f);
            xh[j] += h;
            xdot(st, xh, dxh);
            for (uint8_t i = 0; i < n; i++) {
                st->J[i * n + j] = (i == j ? 1.0f : 0.0f) + st->p.T * (dxh[i] - dx[i]) / h;
            }
        }
        d_hat = isfinite(d_hat) ? d_hat : 0.0f;
        put_f32(out, st->x[0]);
        st->d_x = dx[0];
        for (uint8_t i = 0; i < n; i++) {
            st->x[i] += st->p.T * dx[i];
        }
        mat_mul_f32(st->J, st->P, n, n, n, st->tmp);
        mat_mul_bt_f32(st->tmp, st->J, n, n, n, st->P);
        st->P[0] += st->p.q_v;
        for (uint8_t i = 1; i + 2u < n; i++) {
            st->P[i * n + i] += st->p.q_lat;
        }
        st->P[a * n + a] += st->p.q_w;
        st->P[(a + 1u) * n + a + 1u] += st->p.q_w;
        if (!isfinite(st->x[0]) || !isfinite(st->P[0])) {
            status |= STATUS_NOT_FINITE;
        }
        put_f32(out + 4, d_hat);
        return status;
    }
    put_f32(out, st->x[0]);
    put_f32(out + 4, d_hat);
    return status;
}

static uint8_t uiiekf_configure(void *state, uint8_t mode, const uint8_t *params)
{
    uiiekf_state_t *st = state;
    uint8_t bad = params_check(params, mode, ranges, N_PARAMS);
    if (bad != 0) {
        return bad;
    }
    uint8_t n = (uint8_t)get_f32(params + 4u * P_N);
    if (n != 3u && n != 5u) {
        return 1u + P_N;
    }
    uiiekf_params_t *p = &st->p;
    p->T = get_f32(params + 4u * P_T);
    p->n = n;
    p->iterations = (uint8_t)get_f32(params + 4u * P_ITER);
    p->form = get_f32(params + 4u * P_FORM) >= 0.5f;
    memcpy(p->tire, surfaces[(uint8_t)get_f32(params + 4u * P_SURF)], sizeof p->tire);
    p->p0 = get_f32(params + 4u * P_P0);
    p->q_v = get_f32(params + 4u * P_QV);
    p->q_lat = get_f32(params + 4u * P_QLAT);
    p->q_w = get_f32(params + 4u * P_QW);
    p->r_meas = get_f32(params + 4u * P_R);
    reset(st);
    return 0;
}

static void uiiekf_reset(void *state) { reset(state); }

const estimator_t uiiekf_estimator = {
    .id = UIIEKF_ID,
    .name = "uiiekf",
    .modes = 1u << MODE_F32,
    .n_inputs = 2,
    .n_outputs = 2,
    .n_params = N_PARAMS,
    .configure = uiiekf_configure,
    .reset = uiiekf_reset,
    .step = uiiekf_step,
};
