#include "estimators/longit.h"

#include <math.h>

#include "fixmath/fixmath.h"
#include "proto/messages.h"
#include "proto/wire.h"

const ROM param_range_t longit_ranges[LONGIT_N_PARAMS] = {
    {0.0f, 0.1f, 30},  {0.5f, 2.0f, 24}, {9.0f, 10.5f, 24}, {100.0f, 30000.0f, 16},
    {0.0f, 20.0f, 24}, {1e-3f, 1.0f, 30}, {0.0f, 50.0f, 16},
};

uint8_t longit_check(const uint8_t *params, uint8_t mode, const param_range_t *own, uint8_t n_own)
{
    uint8_t bad = params_check(params, mode, own, n_own);
    if (bad == 0u) {
        bad = params_check(params + 4u * n_own, mode, longit_ranges, LONGIT_N_PARAMS);
        bad = bad ? (uint8_t)(bad + n_own) : 0u;
    }
    if (bad == 0u && mode == MODE_FIXED && param_q(params, n_own + LONGIT_PREFILTER_HZ) != 0) {
        bad = (uint8_t)(1u + n_own + LONGIT_PREFILTER_HZ); /* no prefilter in fixed point */
    }
    return bad;
}

static float shared(const uint8_t *params, uint8_t first, uint8_t i, uint8_t mode)
{
    return param_value(params, (uint8_t)(first + i), mode, param_range_q(longit_ranges, i));
}

void longit_configure(longit_t *l, const uint8_t *params, uint8_t first, uint8_t mode)
{
    l->eps = shared(params, first, LONGIT_EPS, mode);
    l->half_rho = 0.5f * shared(params, first, LONGIT_RHO, mode);
    l->g_cos = shared(params, first, LONGIT_G, mode) / cosf(l->eps);
    l->m0 = shared(params, first, LONGIT_M0, mode);
    l->cda0 = shared(params, first, LONGIT_CDA0, mode);
    l->T = shared(params, first, LONGIT_T, mode);
    float hz = shared(params, first, LONGIT_PREFILTER_HZ, mode);
    l->filter = hz > 0.0f;
    /* Butterworth by the bilinear transform, prewarped to hz. */
    float k = tanf(3.14159265f * hz * l->T);
    float norm = 1.0f / (1.0f + 1.41421356f * k + k * k);
    l->b0 = k * k * norm;
    l->a1 = 2.0f * (k * k - 1.0f) * norm;
    l->a2 = (1.0f - 1.41421356f * k + k * k) * norm;
    longit_reset(l);
}

void longit_configure_q(longit_q_t *l, const uint8_t *params, uint8_t first)
{
    uint8_t st = 0; /* the ranges checked keep every operation below in range */
    int32_t c;
    l->eps = param_q(params, (uint8_t)(first + LONGIT_EPS));
    fx_small_cos_sin_q30(l->eps, &c, &l->sin_eps, &st);
    l->half_rho = param_q(params, (uint8_t)(first + LONGIT_RHO)) / 2;
    l->g_cos = fx_div(param_q(params, (uint8_t)(first + LONGIT_G)), 24, c, 30, 26, &st);
    l->m0 = param_q(params, (uint8_t)(first + LONGIT_M0));
    l->cda0 = param_q(params, (uint8_t)(first + LONGIT_CDA0));
}

void longit_reset(longit_t *l) { l->started = 0; }

/* One sample through the prefilter (transposed direct form II), settled at the first. */
static void prefilter(longit_t *l, float *x)
{
    for (uint8_t c = 0; c < 3u; c++) {
        float *s = l->s[c];
        if (!l->started) {
            s[0] = (1.0f - l->b0) * x[c];
            s[1] = (l->b0 - l->a2) * x[c];
        }
        float y = l->b0 * x[c] + s[0];
        s[0] = 2.0f * l->b0 * x[c] - l->a1 * y + s[1];
        s[1] = l->b0 * x[c] - l->a2 * y;
        x[c] = y;
    }
    l->started = 1;
}

uint8_t longit_past_bounds(const uint8_t *in)
{
    float v = fabsf(get_f32(in)), v_dot = fabsf(get_f32(in + 4)), z = fabsf(get_f32(in + 8));
    return v > LONGIT_V_MAX || v_dot > LONGIT_VDOT_MAX || z > LONGIT_Z_MAX ? STATUS_CLAMPED : 0u;
}

/* x within ±bound, STATUS_CLAMPED into *status if it was not (as FIXED's clamp). */
static float bounded(float x, float bound, uint8_t *status)
{
    if (x > bound || x < -bound) {
        *status |= STATUS_CLAMPED;
        return x > 0.0f ? bound : -bound;
    }
    return x;
}

uint8_t longit_inputs(longit_t *l, const uint8_t *in, float *psi, float *z)
{
    float v = get_f32(in), v_dot = get_f32(in + 4), f = get_f32(in + 8);
    if (!isfinite(v) || !isfinite(v_dot) || !isfinite(f)) {
        return STATUS_NOT_FINITE;
    }
    uint8_t status = 0;
    v = bounded(v, LONGIT_V_MAX, &status);
    float x[3] = {bounded(v_dot, LONGIT_VDOT_MAX, &status), l->half_rho * v * v,
                  bounded(f, LONGIT_Z_MAX, &status)};
    if (l->filter) {
        prefilter(l, x);
    }
    psi[0] = x[0];
    psi[1] = x[1];
    psi[2] = l->g_cos;
    *z = x[2];
    return status;
}

static int32_t clamp(int32_t x, int32_t bound, uint8_t *status)
{
    if (x > bound || x < -bound) {
        *status |= STATUS_CLAMPED;
        return x > 0 ? bound : -bound;
    }
    return x;
}

void longit_inputs_q(const longit_q_t *l, const uint8_t *in, int32_t *x, uint8_t *status)
{
    int32_t v = clamp(get_i32(in), LONGIT_V_MAX_Q24, status);
    int32_t v2 = fx_mul(v, 24, v, 24, 18, status);
    x[0] = clamp(get_i32(in + 4), LONGIT_VDOT_MAX_Q24, status);
    x[1] = fx_mul(v2, 18, l->half_rho, 24, 18, status);
    x[2] = clamp(get_i32(in + 8), LONGIT_Z_MAX_Q14, status);
}

void longit_initial(const longit_t *l, float *theta)
{
    theta[0] = l->m0;
    theta[1] = l->cda0;
    theta[2] = l->m0 * sinf(l->eps);
}

uint8_t longit_outputs(const longit_t *l, float m, float cda, float m_sin, uint8_t *out)
{
    uint8_t status = 0;
    float ratio = 0.0f;
    if (m > 0.0f) {
        ratio = m_sin / m;
    }
    if (!(m > 0.0f) || ratio > 1.0f || ratio < -1.0f) {
        status = STATUS_CLAMPED;
        ratio = ratio > 1.0f ? 1.0f : (ratio < -1.0f ? -1.0f : ratio);
    }
    put_f32(out, m);
    put_f32(out + 4, cda);
    put_f32(out + 8, (asinf(ratio) - l->eps) * 57.2957795f /* deg per rad */);
    return status;
}

void longit_outputs_q(const longit_q_t *l, int32_t m, uint8_t q_m, int32_t cda, int32_t m_sin,
                      uint8_t q_ms, uint8_t *out, uint8_t *status)
{
    int32_t ratio = 0;
    if (m > 0) {
        /* a ratio past Q30's ±2 is past asin's ±1: CLAMPED there, as float32 says it */
        uint8_t past = 0;
        ratio = fx_div(m_sin, q_ms, m, q_m, 30, &past);
        *status |= past ? STATUS_CLAMPED : 0u;
    } else {
        *status |= STATUS_CLAMPED;
    }
    longit_outputs_ratio_q(l, fx_rescale(m, q_m, 16, status), cda, ratio, out, status);
}

void longit_outputs_ratio_q(const longit_q_t *l, int32_t m, int32_t cda, int32_t ratio,
                            uint8_t *out, uint8_t *status)
{
    int32_t grade = fx_sub(fx_asin_q30(ratio, status), l->eps, status); /* clamps |ratio| > 1 */
    put_i32(out, m);
    put_i32(out + 4, cda);
    put_i32(out + 8, fx_mul(grade, 30, 961263669 /* 180/π, Q24 */, 24, 20, status));
}
