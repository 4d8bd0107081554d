#include "estimators/susp_ecu.h"

#include <string.h>

#include "proto/wire.h"

uint8_t susp_ecu_check(const uint8_t *params, uint8_t mode, const param_range_t *own,
                       uint8_t first)
{
    uint8_t bad = params_check(params, mode, own, first);
    if (bad != 0) {
        return bad;
    }
    static const struct {
        const param_range_t *ranges;
        uint8_t n;
    } blocks[] = {
        {accel_cond_ranges, ACCEL_COND_N_PARAMS},
        {qcar_ranges, QCAR_N_PARAMS},
        {susp_ctrl_ranges, SUSP_CTRL_N_PARAMS},
    };
    for (uint8_t b = 0; b < 3u; b++) {
        bad = params_check(params + 4u * first, mode, blocks[b].ranges, blocks[b].n);
        if (bad != 0) {
            return (uint8_t)(first + bad);
        }
        first = (uint8_t)(first + blocks[b].n);
    }
    return 0;
}

void susp_ecu_configure_f32(susp_ecu_f32_t *e, const uint8_t *params, uint8_t first,
                            uint8_t mode, float T)
{
    accel_cond_design_f32(&e->cond, params, first, mode, T);
    qcar_read_f32(&e->model, params, (uint8_t)(first + ACCEL_COND_N_PARAMS), mode);
    susp_ctrl_design_f32(&e->ctrl, params, (uint8_t)(first + ACCEL_COND_N_PARAMS + QCAR_N_PARAMS),
                         mode, &e->model);
    susp_ecu_reset_f32(e);
}

uint8_t susp_ecu_q_from_f32(susp_ecu_q_t *q, const susp_ecu_f32_t *e)
{
    uint8_t status = 0; /* the ranges keep the conditioning's and the model's factors below 128 */
    accel_cond_q_from_f32(&q->cond, &e->cond, &status);
    qcar_q_from_f32(&q->model, &e->model, &status);
    uint8_t bad = susp_ctrl_q_from_f32(&q->ctrl, &e->ctrl);
    susp_ecu_reset_q(q);
    return bad != 0 ? (uint8_t)(ACCEL_COND_N_PARAMS + QCAR_N_PARAMS + bad) : 0u;
}

void susp_ecu_reset_f32(susp_ecu_f32_t *e)
{
    memset(e->ch, 0, sizeof e->ch);
    e->u = 0.0f;
}

void susp_ecu_reset_q(susp_ecu_q_t *e)
{
    memset(e->ch, 0, sizeof e->ch);
    e->u = 0;
}

void susp_ecu_put_f32(uint8_t *out, const susp_est_f32_t *est, float u)
{
    const float v[SUSP_ECU_N_OUTPUTS] = {est->x_s, est->v_s, est->x_us, est->v_us,
                                         est->F1,  est->F2,  est->x_r,  u};
    for (uint8_t i = 0; i < SUSP_ECU_N_OUTPUTS; i++) {
        put_f32(out + 4u * i, v[i]);
    }
}

void susp_ecu_put_q(uint8_t *out, const susp_est_q_t *est, int32_t u)
{
    /* field by field: an array of them first cost the step ~50 cycles of copies */
    put_i32(out, est->x_s);
    put_i32(out + 4, est->v_s);
    put_i32(out + 8, est->x_us);
    put_i32(out + 12, est->v_us);
    put_i32(out + 16, est->F1);
    put_i32(out + 20, est->F2);
    put_i32(out + 24, est->x_r);
    put_i32(out + 28, u);
}
