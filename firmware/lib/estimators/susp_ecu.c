#include "estimators/susp_ecu.h"

#include <string.h>

/* The outputs go on the wire as the structs' own bytes: the wire is little-endian, int32 and
 * IEEE-754 binary32, as the AVR and the host are. One copy, where stores field by field cost
 * the FIXED step ~90 cycles of moves. */
#if __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "susp_ecu_put_* copy the outputs as the wire's little-endian bytes"
#endif

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
    uint8_t bad = accel_cond_q_from_f32(&q->cond, &e->cond, &status);
    if (bad != 0) {
        return bad; /* the conditioning's parameters come first in the tail */
    }
    qcar_q_from_f32(&q->model, &e->model, &status);
    bad = susp_ctrl_q_from_f32(&q->ctrl, &e->ctrl);
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
    memcpy(out, est, sizeof *est);
    memcpy(out + sizeof *est, &u, sizeof u);
}

void susp_ecu_put_q(uint8_t *out, const susp_est_q_t *est, int32_t u)
{
    memcpy(out, est, sizeof *est);
    memcpy(out + sizeof *est, &u, sizeof u);
}
