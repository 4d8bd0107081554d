#include "estimators/longit.h"

#include <math.h>

#include "proto/messages.h"
#include "proto/wire.h"

const param_range_t longit_ranges[LONGIT_N_PARAMS] = {
    {0.0f, 0.1f, 30}, {0.5f, 2.0f, 24}, {9.0f, 10.5f, 24}, {100.0f, 30000.0f, 16}, {0.0f, 20.0f, 24},
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

void longit_configure(longit_t *l, const uint8_t *params, uint8_t first)
{
    l->eps = get_f32(params + 4u * (first + LONGIT_EPS));
    l->half_rho = 0.5f * get_f32(params + 4u * (first + LONGIT_RHO));
    l->g_cos = get_f32(params + 4u * (first + LONGIT_G)) / cosf(l->eps);
    l->m0 = get_f32(params + 4u * (first + LONGIT_M0));
    l->cda0 = get_f32(params + 4u * (first + LONGIT_CDA0));
}

uint8_t longit_inputs(const longit_t *l, const uint8_t *in, float *psi, float *z)
{
    float v = get_f32(in), v_dot = get_f32(in + 4);
    *z = get_f32(in + 8);
    if (!isfinite(v) || !isfinite(v_dot) || !isfinite(*z)) {
        return STATUS_NOT_FINITE;
    }
    psi[0] = v_dot;
    psi[1] = l->half_rho * v * v;
    psi[2] = l->g_cos;
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
