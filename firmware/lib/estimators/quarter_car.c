#include "estimators/quarter_car.h"

#include "fixmath/fixmath.h"

const ROM param_range_t qcar_ranges[QCAR_N_PARAMS] = {
    {50.0f, 2000.0f, 16}, {35.0f, 500.0f, 16},  {0.0f, 1e6f, 8},     {-5e6f, 5e6f, 8},
    {-8e6f, 8e6f, 8},     {0.0f, 2e4f, 16},     {-2e4f, 2e4f, 16},   {1e4f, 2e6f, 8},
};

void qcar_read_f32(qcar_f32_t *m, const uint8_t *params, uint8_t first, uint8_t mode)
{
    float v[QCAR_N_PARAMS];
    for (uint8_t i = 0; i < QCAR_N_PARAMS; i++) {
        v[i] = param_value(params, (uint8_t)(first + i), mode, param_range_q(qcar_ranges, i));
    }
    *m = (qcar_f32_t){v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]};
}

void qcar_q_from_f32(qcar_q_t *q, const qcar_f32_t *m, uint8_t *status)
{
    float inv_k = 1.0f / m->k_us;
    *q = (qcar_q_t){
        .k2 = fx_from_float(m->k2, 8, status),
        .k3 = fx_factor(m->k3, -20, status),
        .c2 = fx_factor(m->c2, -8, status),
        .inv_m_s = fx_factor(1.0f / m->m_s, 4, status),
        .inv_m_us = fx_factor(1.0f / m->m_us, 4, status),
        .r_m_us = fx_factor(m->m_us * inv_k, 8, status),
        .r_m_s = fx_factor(m->m_s * inv_k, 8, status),
        .r_k1 = fx_factor(m->k1 * inv_k, 0, status),
        .r_c1 = fx_factor(m->c1 * inv_k, 4, status),
        .r_force = fx_factor(inv_k, 12, status),
    };
}

float qcar_strut_f32(const qcar_f32_t *m, float dx, float dv, uint8_t nonlinear_only)
{
    float f = dx * dx * (m->k2 + m->k3 * dx) + m->c2 * dv * dv; /* eq. 2, literal square */
    return nonlinear_only ? f : f + m->k1 * dx + m->c1 * dv;
}

int32_t qcar_strut_nl_q(const qcar_q_t *m, int32_t dx, int32_t dv, uint8_t *status)
{
    int32_t k = fx_add(m->k2, fx_mul_f(dx, m->k3, status), status); /* Q8 */
    int32_t dx2 = fx_mul(dx, 28, dx, 28, 28, status);
    int32_t dv2 = fx_mul(dv, 24, dv, 24, 24, status);
    return fx_add(fx_mul(k, 8, dx2, 28, 16, status), fx_mul_f(dv2, m->c2, status), status);
}
