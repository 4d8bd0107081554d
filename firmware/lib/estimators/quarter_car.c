#include "estimators/quarter_car.h"

#include <stddef.h>

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
        .s1 = fx_from_float(m->k1 * inv_k, 20, status),
        .s2 = fx_from_float(m->k2 * inv_k, 20, status),
        .s3 = fx_from_float(m->k3 * inv_k, 20, status),
        .d1 = fx_from_float(m->c1 * inv_k, 24, status),
        .d2 = fx_from_float(m->c2 * inv_k, 28, status),
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

/* x 2^-12 rounded half up, in an int16 (saturated, flagged): bits 12..27 of x + 2^11 by
 * 16-bit nibble shifts, where a 32-bit shift by 12 is a loop on the AVR. */
static int16_t drop12_int16(int32_t x, uint8_t *status)
{
    if (x >= ((int32_t)1 << 27) - 2048 || x < -((int32_t)1 << 27) - 2048) {
        *status |= STATUS_SATURATED;
        return x < 0 ? INT16_MIN : INT16_MAX;
    }
    uint32_t t = (uint32_t)x + 2048u;
    return (int16_t)(((uint16_t)(t >> 16) << 4) | ((uint16_t)t >> 12));
}

/* round(p x 2^-16), half up on p |x| with x's sign then applied: below 2^30, no saturation. */
static int32_t times_x16(int32_t p, int16_t x)
{
    uint16_t x_abs = (uint16_t)(x < 0 ? -(int32_t)x : x);
    int32_t r = fx_smul_f(p, (fx_ufactor_t){x_abs, 16});
    return x < 0 ? -r : r;
}

/* x 2^-5 rounded half up, in 24 bits (saturated past ±2^23, flagged): Δx Q28 -> Q23, ±1 m */
static int32_t drop5_int24(int32_t x, uint8_t *status)
{
    if (x >= ((int32_t)1 << 28) - 16 || x < -((int32_t)1 << 28) - 16) {
        *status |= STATUS_SATURATED;
        return x < 0 ? -((int32_t)1 << 23) : ((int32_t)1 << 23) - 1;
    }
    return (x + 16) >> 5;
}

/* round(p x 2^-23), half up on p |x| with x's sign then applied (wrapping at p = INT32_MIN,
 * x = -2^23 alone, as the AVR's negation does): |p x| 2^-23 <= |p|, no saturation. */
static int32_t times_x24(int32_t p, int32_t x)
{
    uint32_t r = (uint32_t)(((int64_t)p * (x < 0 ? -x : x) + ((int64_t)1 << 22)) >> 23);
    return (int32_t)(x < 0 ? 0u - r : r);
}

int32_t qcar_strut_over_kus_q_c(const qcar_q_t *m, int32_t dx, int32_t dv, uint8_t *status)
{
    int32_t x = drop5_int24(dx, status);  /* m Q28 -> Q23 */
    int16_t v = drop12_int16(dv, status); /* m/s Q24 -> Q12 */
    /* (k1 + Δx (k2 + k3 Δx)) Δx / k_us in Q20 (|Δx| <= 1 keeps each sum below 1,400 over the
     * parameters' ranges) and (c1 + c2 Δẋ) Δẋ / k_us, the sum in Q24 (below 18 for
     * |Δẋ| <= 8), then Q20 */
    int32_t p = fx_add(m->s2, times_x24(m->s3, x), status);
    p = fx_add(m->s1, times_x24(p, x), status);
    int32_t d = fx_add(m->d1, times_x16(m->d2, v), status);
    int32_t strut = fx_add(times_x24(p, x), times_x16(d, v), status);
    return fx_rescale(strut, 20, 28, status);
}

#if defined(__AVR__)
/* quarter_car_avr.S reads qcar_q_t at these offsets */
FX_ASM_OFFSET(qcar_q_t, s1, 22);
FX_ASM_OFFSET(qcar_q_t, s2, 26);
FX_ASM_OFFSET(qcar_q_t, s3, 30);
FX_ASM_OFFSET(qcar_q_t, d1, 34);
FX_ASM_OFFSET(qcar_q_t, d2, 38);
#endif
