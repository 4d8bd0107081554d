#include "estimators/uiiekf.h"

#include <math.h>
#include <string.h>

#include "estimators/health.h"
#include "estimators/params.h"
#include "proto/wire.h"

enum {
    P_T, P_N, P_ITER, P_FORM, P_C1, P_C2, P_C3, P_P0, P_QV, P_QLAT, P_QW, P_R,
    P_M, P_RW, P_IW, P_KB, P_PSI, P_HCG, P_LF, P_LR, P_VMAX, P_NISMAX, P_VMIN, P_NISWIN,
    P_IZ, P_RHO, P_CD, P_AF, P_HA, P_G, N_PARAMS
};

static const ROM param_range_t ranges[N_PARAMS] = {
    {1e-4f, 0.1f, 0},     {3.0f, 5.0f, 0},   {1.0f, 10.0f, 0},  {0.0f, 1.0f, 0},
    {0.0f, 2.0f, 0},      {1.0f, 500.0f, 0}, {0.0f, 1.0f, 0},   {1e-6f, 1e3f, 0},
    {0.0f, 1e3f, 0},      {0.0f, 1e3f, 0},   {0.0f, 1e5f, 0},   {1e-6f, 100.0f, 0},
    {100.0f, 5000.0f, 0}, {0.1f, 1.0f, 0},   {0.05f, 50.0f, 0}, {0.0f, 1.0f, 0},
    {0.1f, 1.5f, 0},      {0.1f, 2.0f, 0},   {0.3f, 4.0f, 0},   {0.3f, 4.0f, 0},
    {1.0f, 200.0f, 0},    {1.0f, 1e6f, 0},   {0.0f, 10.0f, 0},  {0.1f, 100.0f, 0},
    {50.0f, 20000.0f, 0}, {0.5f, 1.5f, 0},   {0.0f, 2.0f, 0},   {0.5f, 10.0f, 0},
    {0.0f, 3.0f, 0},      {9.0f, 10.5f, 0},
};

/* One wheel's braking-positive forces and their partials by (v, v_lat, ω). The filter
 * assumes δ = 0, and at v_lat = 0 the lateral block decouples from the wheels exactly
 * (∂F_x/∂v_lat = ∂F_y/∂ω = ∂F_y/∂v = 0): from v_y = r = 0 and a diagonal P(0) the
 * 5-state filter's v_y and r never leave zero, so v_lat = 0 here always. Then s_y = 0,
 * s = |s_x| with s_x = 1 - R ω / v, F_x = sgn(s_x) μ(|s_x|) F_z (μ(s) = ψ (c1 (1 - e^{-c2 s})
 * - c3 s)), ∂F_x = μ'(|s_x|) F_z ∂s_x, and the one lateral partial is the cornering
 * stiffness ∂F_y/∂v_lat = -(μ/s) F_z R ω / v², needed by the 5-state filter only
 * (`lateral`). The reference (uiiekf.py) keeps the general slip of eqs. 9-16. */
typedef struct {
    float f_x, dv, dw, dy; /* F_x, ∂F_x/∂v, ∂F_x/∂ω, ∂F_y/∂v_lat */
} wheel_t;

static void wheel(const uiiekf_params_t *p, float w, float v, float f_z, float df_z,
                  uint8_t lateral, wheel_t *o)
{
    float inv_v = 1.0f / v, a = p->r_w * w * inv_v;
    float s_x = 1.0f - a, s = fabsf(s_x), ex = expf(-p->c2 * s);
    float mu = p->psi_c1 * (1.0f - ex) - p->psi_c3 * s;
    float signed_mu = s_x < 0.0f ? -mu : mu;
    float k = (p->psi_c1c2 * ex - p->psi_c3) * f_z * inv_v; /* μ' F_z / v */
    o->f_x = signed_mu * f_z;
    o->dv = k * a + signed_mu * df_z;
    o->dw = -k * p->r_w;
    o->dy = lateral ? -(s < 1e-6f ? p->g0 : mu / s) * f_z * a * inv_v : 0.0f;
}

/* ẋ of eqs. 2-16 (δ = 0, no brake torque: it is the unknown input) and A = ∂ẋ/∂x for
 * the five model states at v_y = r = 0; d_x, the model's last v̇_x, is held in A. */
static void model(const uiiekf_params_t *p, const float *x, float d_x, float *f, float A[5][5])
{
    float v = x[0] > 0.1f ? x[0] : 0.1f, dv = x[0] > 0.1f ? 1.0f : 0.0f;
    float transfer = p->transfer * d_x, drag = p->drag * v * v, ddrag = 2.0f * p->drag * v * dv;
    const float f_z[2] = {p->load_f - transfer - drag, p->load_r + transfer + drag};
    const float lever[2] = {p->l_f, -p->l_r};
    memset(A, 0, 25 * sizeof(float));
    f[0] = f[1] = f[2] = 0.0f;
    for (uint8_t i = 0; i < 2u; i++) {
        uint8_t w_i = (uint8_t)(3u + i), loaded = f_z[i] > 0.0f;
        wheel_t o;
        wheel(p, x[w_i], v, loaded ? f_z[i] : 0.0f, loaded ? (i == 0u ? -ddrag : ddrag) : 0.0f,
              p->n == 5u, &o);
        f[0] -= p->two_inv_m * o.f_x;
        f[w_i] = p->r_w_inv_i_w * o.f_x;
        A[0][0] -= p->two_inv_m * dv * o.dv;
        A[0][w_i] = -p->two_inv_m * o.dw;
        A[w_i][0] = p->r_w_inv_i_w * dv * o.dv;
        A[w_i][w_i] = p->r_w_inv_i_w * o.dw;
        /* the lateral block, through v_lat = v_y + ℓ r */
        float dy = p->two_inv_m * o.dy, yaw = p->two_inv_i_z * lever[i] * o.dy;
        A[1][1] += dy;
        A[1][2] += dy * lever[i];
        A[2][1] += yaw;
        A[2][2] += yaw * lever[i];
    }
    A[1][2] -= v; /* v̇_y = ... - r v */
}

/* The filter's states among the model's five. */
static const uint8_t full_index[2][5] = {{0, 3, 4, 0, 0}, {0, 1, 2, 3, 4}};

/* Eq. 37: x = x + T ẋ, P = J P Jᵀ + Q with J = I + T A. */
static void time_update(uiiekf_state_t *st)
{
    const uiiekf_params_t *p = &st->p;
    uint8_t n = p->n;
    const uint8_t *idx = full_index[n == 5u];
    float x5[5] = {st->x[0], 0.0f, 0.0f, 0.0f, 0.0f}, f[5], A[5][5], J[5][5], M[5][5];
    for (uint8_t i = 1; i < n; i++) {
        x5[idx[i]] = st->x[i];
    }
    model(p, x5, st->d_x, f, A);
    st->d_x = f[0];
    for (uint8_t i = 0; i < n; i++) {
        st->x[i] += p->T * f[idx[i]];
        for (uint8_t j = 0; j < n; j++) {
            J[i][j] = (i == j ? 1.0f : 0.0f) + p->T * A[idx[i]][idx[j]];
        }
    }
    /* M = J P, then P = M Jᵀ on the upper triangle, over J's non-zero entries (in a
     * straight line the lateral block decouples: 11 of 25 in the 5-state filter). */
    uint8_t nz[5][5], n_nz[5];
    for (uint8_t i = 0; i < n; i++) {
        n_nz[i] = 0;
        for (uint8_t k = 0; k < n; k++) {
            if (J[i][k] != 0.0f) {
                nz[i][n_nz[i]++] = k;
            }
        }
    }
    for (uint8_t i = 0; i < n; i++) {
        for (uint8_t j = 0; j < n; j++) {
            float s = 0.0f;
            for (uint8_t m = 0; m < n_nz[i]; m++) {
                s += J[i][nz[i][m]] * st->P[nz[i][m]][j];
            }
            M[i][j] = s;
        }
    }
    for (uint8_t i = 0; i < n; i++) {
        for (uint8_t j = i; j < n; j++) {
            float s = 0.0f;
            for (uint8_t m = 0; m < n_nz[j]; m++) {
                s += M[i][nz[j][m]] * J[j][nz[j][m]];
            }
            st->P[i][j] = st->P[j][i] = s;
        }
    }
    st->P[0][0] += p->q_v;
    for (uint8_t i = 1; i + 2u < n; i++) {
        st->P[i][i] += p->q_lat;
    }
    st->P[n - 2u][n - 2u] += p->q_w;
    st->P[n - 1u][n - 1u] += p->q_w;
}

/* One pass of eq. 36: L = K + (I - K C) B (Bᵀ Cᵀ F⁻¹ C B)⁻¹ Bᵀ Cᵀ F⁻¹, x += L e and
 * P = (I - L C) P (I - L C)ᵀ + r L Lᵀ (Joseph's form: float32 keeps it accurate where P
 * shrinks a thousandfold), which with C picking the wheels (rows a, a + 1) is
 * P - L (C P) - N Lᵀ, N = P Cᵀ - L C P Cᵀ - r L. A state the wheels do not see (its rows a,
 * a + 1 of P zero: v_y and r in a straight line) has L_i = N_i = 0 and keeps its rows.
 * *nis (if not NULL): eᵀ F⁻¹ e less its part along C B, a χ²(1) value. */
static uint8_t measurement_update(uiiekf_state_t *st, const float *z, float *nis)
{
    const uiiekf_params_t *p = &st->p;
    uint8_t n = p->n, a = (uint8_t)(n - 2u), b = (uint8_t)(n - 1u);
    float (*P)[UIIEKF_MAX_STATES] = st->P;
    float r = p->r_meas, cb0 = p->cb[0], cb1 = p->cb[1];
    float det = (P[a][a] + r) * (P[b][b] + r) - P[a][b] * P[a][b];
    if (!(det > 0.0f)) {
        return STATUS_SINGULAR;
    }
    float inv_det = 1.0f / det; /* F⁻¹ = [f0 f1; f1 f3] */
    float f0 = (P[b][b] + r) * inv_det, f1 = -P[a][b] * inv_det, f3 = (P[a][a] + r) * inv_det;
    float w0 = cb0 * f0 + cb1 * f1, w1 = cb0 * f1 + cb1 * f3; /* Bᵀ Cᵀ F⁻¹ */
    float g = w0 * cb0 + w1 * cb1;
    if (!(g > 0.0f)) {
        return STATUS_SINGULAR;
    }
    float inv_g = 1.0f / g;
    float e0 = z[0] - st->x[a], e1 = z[1] - st->x[b];
    if (nis != NULL) {
        float we = w0 * e0 + w1 * e1;
        *nis = e0 * (f0 * e0 + f1 * e1) + e1 * (f1 * e0 + f3 * e1) - we * we * inv_g;
    }
    float L[UIIEKF_MAX_STATES][2], N[UIIEKF_MAX_STATES][2], pa[UIIEKF_MAX_STATES],
        pb[UIIEKF_MAX_STATES];
    uint8_t seen[UIIEKF_MAX_STATES];
    for (uint8_t i = 0; i < n; i++) {
        pa[i] = P[a][i];
        pb[i] = P[b][i];
        seen[i] = pa[i] != 0.0f || pb[i] != 0.0f;
        if (!seen[i]) {
            continue;
        }
        float k0 = pa[i] * f0 + pb[i] * f1, k1 = pa[i] * f1 + pb[i] * f3; /* K = P Cᵀ F⁻¹ */
        float b_i = i == a ? cb0 : (i == b ? cb1 : 0.0f);                 /* B's rows */
        float v = (b_i - (k0 * cb0 + k1 * cb1)) * inv_g;                  /* (I - K C) B / g */
        L[i][0] = k0 + v * w0;
        L[i][1] = k1 + v * w1;
        st->x[i] += L[i][0] * e0 + L[i][1] * e1;
    }
    for (uint8_t i = 0; i < n; i++) {
        if (seen[i]) {
            N[i][0] = pa[i] - (L[i][0] * pa[a] + L[i][1] * pb[a]) - r * L[i][0];
            N[i][1] = pb[i] - (L[i][0] * pa[b] + L[i][1] * pb[b]) - r * L[i][1];
        }
    }
    for (uint8_t i = 0; i < n; i++) {
        for (uint8_t j = i; j < n && seen[i]; j++) {
            if (seen[j]) {
                P[i][j] = P[j][i] = P[i][j] - (L[i][0] * pa[j] + L[i][1] * pb[j]) -
                                    (N[i][0] * L[j][0] + N[i][1] * L[j][1]);
            }
        }
    }
    return 0;
}

/* The health check (docs/estimators/uiiekf.md): a variance is negative, or the speed's is
 * above v_max²; and, on the updated estimate, the windowed NIS passes its limit, the
 * speed is 3σ outside [0, v_max] or a wheel's 3σ outside [0, v_max / R] (turning backwards). */
static uint8_t covariance_ok(const uiiekf_state_t *st)
{
    uint8_t ok = st->P[0][0] <= st->p.v_max2;
    for (uint8_t i = 0; i < st->p.n; i++) {
        ok = ok && st->P[i][i] >= 0.0f;
    }
    return ok;
}

static uint8_t estimate_ok(const uiiekf_state_t *st)
{
    const uiiekf_params_t *p = &st->p;
    uint8_t a = (uint8_t)(p->n - 2u), b = (uint8_t)(p->n - 1u);
    return st->nis <= p->nis_max && covariance_ok(st) &&
           !health_outside_3sigma(st->x[0], 0.0f, p->v_max, st->P[0][0]) &&
           !health_outside_3sigma(st->x[a], 0.0f, p->w_max, st->P[a][a]) &&
           !health_outside_3sigma(st->x[b], 0.0f, p->w_max, st->P[b][b]);
}

static void reset(uiiekf_state_t *st)
{
    memset(st->x, 0, sizeof st->x);
    memset(st->P, 0, sizeof st->P);
    for (uint8_t i = 0; i < st->p.n; i++) {
        st->P[i][i] = st->p.p0;
    }
    st->d_x = 0.0f;
    st->nis = 0.0f;
    st->started = 0;
}

static uint8_t uiiekf_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                           uint8_t *out_len)
{
    uiiekf_state_t *st = state;
    const uiiekf_params_t *p = &st->p;
    (void)in_len;
    *out_len = 8;
    uint8_t a = (uint8_t)(p->n - 2u);
    float z[2] = {get_f32(in), get_f32(in + 4)};
    float d_hat = 0.0f, v_out = st->x[0];
    uint8_t status = 0;
    if (!isfinite(z[0]) || !isfinite(z[1])) {
        status = STATUS_NOT_FINITE;
    } else {
        if (!st->started) {
            st->started = 1;
            st->x[0] = p->r_w * z[0]; /* v_x(0) = R ω_f(0) */
            st->x[a] = z[0];
            st->x[a + 1u] = z[1];
        }
        /* d̂ = (C B)⁺ e, from the innovation before the update */
        d_hat = (p->cb[0] * (z[0] - st->x[a]) + p->cb[1] * (z[1] - st->x[a + 1u])) * p->inv_cb2;
        uint8_t passes = p->form ? 1u : p->iterations;
        float nis = 0.0f;
        for (uint8_t i = 0; i < passes && status == 0; i++) {
            status |= measurement_update(st, z, i == 0u ? &nis : NULL);
        }
        if (z[0] >= p->w_min || z[1] >= p->w_min) {
            if (status == 0) {
                st->nis = health_window_mean(st->nis, p->alpha, nis);
            }
        } else {
            /* Standstill: the slip model means nothing, the torque holding the car is a
             * static reaction (d̂ 0: none estimated) and v̂ is the model's alone
             * (docs/estimators/uiiekf.md). */
            status |= STATUS_ILL_CONDITIONED;
            d_hat = 0.0f;
        }
        uint8_t healthy = estimate_ok(st);
        v_out = st->x[0];
        time_update(st);
        if (!healthy || !covariance_ok(st)) {
            status |= STATUS_DIVERGED;
        }
        if (!isfinite(st->x[0]) || !isfinite(st->P[0][0])) {
            status |= STATUS_NOT_FINITE;
        }
        d_hat = isfinite(d_hat) ? d_hat : 0.0f;
    }
    put_f32(out, v_out);
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
    float v[N_PARAMS];
    for (uint8_t i = 0; i < N_PARAMS; i++) {
        v[i] = get_f32(params + 4u * i);
    }
    uint8_t n = (uint8_t)v[P_N];
    if (n != 3u && n != 5u) {
        return 1u + P_N;
    }
    float L2 = 2.0f * (v[P_LF] + v[P_LR]), inv_L2 = 1.0f / L2, weight = v[P_M] * v[P_G];
    float T_iw = v[P_T] / v[P_IW], cb0 = -v[P_KB] * T_iw, cb1 = -(1.0f - v[P_KB]) * T_iw;
    float psi = v[P_PSI], c1 = v[P_C1], c2 = v[P_C2], c3 = v[P_C3];
    st->p = (uiiekf_params_t){
        .T = v[P_T],
        .p0 = v[P_P0],
        .q_v = v[P_QV] * v[P_T], /* densities per second: Q a step is q T */
        .q_lat = v[P_QLAT] * v[P_T],
        .q_w = v[P_QW] * v[P_T],
        .r_meas = v[P_R],
        .r_w = v[P_RW],
        .two_inv_m = 2.0f / v[P_M],
        .two_inv_i_z = 2.0f / v[P_IZ],
        .r_w_inv_i_w = v[P_RW] / v[P_IW],
        .l_f = v[P_LF],
        .l_r = v[P_LR],
        .load_f = weight * v[P_LR] * inv_L2,
        .load_r = weight * v[P_LF] * inv_L2,
        .transfer = v[P_M] * v[P_HCG] * inv_L2,
        .drag = 0.5f * v[P_RHO] * v[P_CD] * v[P_AF] * v[P_HA] * inv_L2, /* ½ ρ C_d A_f H_a */
        .psi_c1 = psi * c1,
        .c2 = c2,
        .psi_c3 = psi * c3,
        .psi_c1c2 = psi * c1 * c2,
        .g0 = psi * (c1 * c2 - c3),
        .cb = {cb0, cb1},
        .inv_cb2 = 1.0f / (cb0 * cb0 + cb1 * cb1),
        .alpha = v[P_T] / v[P_NISWIN], /* T <= 0.1 s <= the window: at most 1 */
        .nis_max = v[P_NISMAX],
        .v_max = v[P_VMAX],
        .v_max2 = v[P_VMAX] * v[P_VMAX],
        .w_max = v[P_VMAX] / v[P_RW],
        .w_min = v[P_VMIN] / v[P_RW],
        .n = n,
        .iterations = (uint8_t)v[P_ITER],
        .form = v[P_FORM] >= 0.5f,
    };
    reset(st);
    return 0;
}

static void uiiekf_reset(void *state) { reset(state); }

const ROM estimator_t uiiekf_estimator = {
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
