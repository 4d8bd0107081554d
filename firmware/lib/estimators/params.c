#include "estimators/params.h"

#include "proto/messages.h"
#include "proto/wire.h"

static float q_scale(uint8_t q)
{
    float s = 1.0f;
    while (q-- > 0u) {
        s *= 0.5f;
    }
    return s;
}

float param_value(const uint8_t *params, uint8_t i, uint8_t mode, uint8_t q)
{
    const uint8_t *p = params + 4u * i;
    return mode == MODE_F32 ? get_f32(p) : (float)get_i32(p) * q_scale(q);
}

int32_t param_q(const uint8_t *params, uint8_t i) { return get_i32(params + 4u * i); }

uint8_t params_check(const uint8_t *params, uint8_t mode, const param_range_t *ranges, uint8_t n)
{
    for (uint8_t i = 0; i < n; i++) {
        float x = param_value(params, i, mode, param_range_q(ranges, i));
        /* Written so that NaN fails too. */
        if (!(x >= rom_float(&ranges[i].lo_rom) && x <= rom_float(&ranges[i].hi_rom))) {
            return (uint8_t)(i + 1u);
        }
    }
    return 0;
}

#define LN2_F 0.693147181f

/* x^k for 0 <= x < 2, k > 0, from IEEE operations alone (libm's last bit differs between
 * avr-libc and the host; CONFIG must derive the same bits on both): ln x from atanh's
 * series once exact doublings bring x into [3/4, 3/2), exp from Taylor's series once whole
 * multiples of ln 2 are taken out. Relative error ~1e-6; results past 2 give 2. */
float param_pow(float x, float k)
{
    if (x <= 0.0f) {
        return 0.0f;
    }
    int8_t e = 0;
    while (x < 0.75f) {
        x *= 2.0f;
        e--;
    }
    while (x >= 1.5f) {
        x *= 0.5f;
        e++;
    }
    float z = (x - 1.0f) / (x + 1.0f), z2 = z * z, term = z, ln = 0.0f;
    for (uint8_t j = 1; j < 20u; j += 2) {
        ln += term / (float)j;
        term *= z2;
    }
    float y = k * (2.0f * ln + (float)e * LN2_F);
    if (y > LN2_F) {
        return 2.0f;
    }
    if (y < -80.0f) {
        return 0.0f;
    }
    int8_t n = 0;
    while (y < -0.5f * LN2_F) {
        y += LN2_F;
        n++;
    }
    float sum = 1.0f, t = 1.0f;
    for (uint8_t j = 1; j < 12u; j++) {
        t *= y / (float)j;
        sum += t;
    }
    while (n-- > 0) {
        sum *= 0.5f;
    }
    return sum;
}
