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
