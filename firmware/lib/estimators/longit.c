#include "estimators/longit.h"

#include <math.h>

#include "proto/messages.h"
#include "proto/wire.h"

const param_range_t longit_ranges[LONGIT_N_PARAMS] = {
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
    return bad;
}

static float shared(const uint8_t *params, uint8_t first, uint8_t i, uint8_t mode)
{
    return param_value(params, (uint8_t)(first + i), mode, longit_ranges[i].q);
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

uint8_t longit_inputs(longit_t *l, const uint8_t *in, float *psi, float *z)
{
    float v = get_f32(in), v_dot = get_f32(in + 4);
    float x[3] = {v_dot, l->half_rho * v * v, get_f32(in + 8)};
    if (!isfinite(v) || !isfinite(v_dot) || !isfinite(x[2])) {
        return STATUS_NOT_FINITE;
    }
    if (l->filter) {
        prefilter(l, x);
    }
    psi[0] = x[0];
    psi[1] = x[1];
    psi[2] = l->g_cos;
    *z = x[2];
    return 0;
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
