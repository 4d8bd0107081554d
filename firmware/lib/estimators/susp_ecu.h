/* What seed 003's two board tasks (eso, kfui) share: the ECU around the observer. Two
 * accelerations in -> conditioning (accel_cond) -> observer -> controller (susp_ctrl)
 * -> [x̂_s, ẋ̂_s, x̂_us, ẋ̂_us, F̂1, F̂2, x̂_r, u] out (fixed point Q28, Q24, Q28, Q24, Q20,
 * Q20, Q28, Q16). The parameter tail both tasks end with: conditioning (3), the nominal
 * model (8), the controller (8). */
#ifndef VEHIL_ESTIMATORS_SUSP_ECU_H
#define VEHIL_ESTIMATORS_SUSP_ECU_H

#include <stdint.h>

#include "estimators/accel_cond.h"
#include "estimators/quarter_car.h"
#include "estimators/susp_ctrl.h"

#define SUSP_ECU_N_PARAMS (ACCEL_COND_N_PARAMS + QCAR_N_PARAMS + SUSP_CTRL_N_PARAMS)
#define SUSP_ECU_N_OUTPUTS 8u

typedef struct {
    accel_cond_f32_t cond;
    qcar_f32_t model;
    susp_ctrl_f32_t ctrl;
    accel_chan_f32_t ch[2];
    float u; /* the force applied over the last sample */
} susp_ecu_f32_t;

typedef struct {
    accel_cond_q_t cond;
    qcar_q_t model;
    susp_ctrl_q_t ctrl;
    accel_chan_q_t ch[2];
    int32_t u; /* Q16 */
} susp_ecu_q_t;

/* 0, or 1 + the index of the first bad parameter: the estimator's own `first` ones
 * (checked against `own`), then the shared tail. */
uint8_t susp_ecu_check(const uint8_t *params, uint8_t mode, const param_range_t *own,
                       uint8_t first);

/* Designs from CONFIG (the tail at `first`); the float model is also what FIXED starts from. */
void susp_ecu_configure_f32(susp_ecu_f32_t *e, const uint8_t *params, uint8_t first,
                            uint8_t mode, float T);
/* 0, or 1 + the index (in the tail) of the parameter whose fixed-point form does not fit. */
uint8_t susp_ecu_q_from_f32(susp_ecu_q_t *q, const susp_ecu_f32_t *e);

/* Memories back to zero (the filters and the held force), the design kept. */
void susp_ecu_reset_f32(susp_ecu_f32_t *e);
void susp_ecu_reset_q(susp_ecu_q_t *e);

/* The estimates and u on the wire, in the output order above. */
void susp_ecu_put_f32(uint8_t *out, const susp_est_f32_t *est, float u);
void susp_ecu_put_q(uint8_t *out, const susp_est_q_t *est, int32_t u);

#endif
