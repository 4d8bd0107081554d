/* The wheel speed the wheel-speed-only braking filters (MANF, ANF) follow: front, rear, or
 * the faster of the two (the less braked), by the `wheel` parameter (0, 1, 2). */
#ifndef VEHIL_ESTIMATORS_WHEEL_CHOICE_H
#define VEHIL_ESTIMATORS_WHEEL_CHOICE_H

#include <stdint.h>

static inline float wheel_choice_f32(uint8_t wheel, float w_f, float w_r)
{
    return wheel == 0u ? w_f : wheel == 1u ? w_r : (w_f > w_r ? w_f : w_r);
}

static inline int32_t wheel_choice_q(uint8_t wheel, int32_t w_f, int32_t w_r)
{
    return wheel == 0u ? w_f : wheel == 1u ? w_r : (w_f > w_r ? w_f : w_r);
}

#endif
