/* Seed 003's pointwise-predictive suspension controller (Sec. 6.2; the law is our
 * reconstruction, host/vehil/estimators/_suspension_control.py). J(u) is
 * quadratic in u, so u* = -Σ ρ_i a_i b_i / (r + Σ ρ_i b_i²) is linear in the estimates:
 * configure folds the weights, the horizon and the model into seven gains,
 *   u* = -(g_F1 F̂1 + g_F2 F̂2 + g_dx Δx + g_dv Δẋ + g_td (x̂_us - x̂_r) + g_vus ẋ̂_us + g_vs ẋ̂_s),
 * then |u| <= u_max (STATUS_CLAMPED when it bites). `active` 0: u = 0 (passive).
 * Params (8): active Q0, ρ_a Q16, ρ_sd Q8, ρ_td Q8, ρ_v Q8, r Q40, h Q30, u_max Q16.
 * Fixed point: each gain a factor (fx_factor_t) from its estimate's Q to N in Q8, the sum
 * rescaled to u's Q16 (0.004 N steps against a u_max of hundreds of N); a gain that does
 * not fit (128 N per unit of the estimate's Q) is refused at CONFIG. */
#ifndef VEHIL_ESTIMATORS_SUSP_CTRL_H
#define VEHIL_ESTIMATORS_SUSP_CTRL_H

#include <stdint.h>

#include "estimators/params.h"
#include "estimators/quarter_car.h"
#include "fixmath/fixmath.h"

#define SUSP_CTRL_N_PARAMS 8u

typedef struct {
    float g_F1, g_F2, g_dx, g_dv, g_td, g_vus, g_vs, u_max;
    uint8_t active;
} susp_ctrl_f32_t;

typedef struct {
    fx_factor_t g_F1, g_F2, g_dx, g_dv, g_td, g_vus, g_vs;
    int32_t u_max; /* Q16 */
    uint8_t active;
} susp_ctrl_q_t;

/* What the controller reads: x̂ (m, m/s), F̂ (m/s²), x̂_r (m). Fixed: Q28/Q24/Q20/Q28. */
typedef struct {
    float x_s, v_s, x_us, v_us, F1, F2, x_r;
} susp_est_f32_t;

typedef struct {
    int32_t x_s, v_s, x_us, v_us, F1, F2, x_r;
} susp_est_q_t;

extern const ROM param_range_t susp_ctrl_ranges[SUSP_CTRL_N_PARAMS];

void susp_ctrl_design_f32(susp_ctrl_f32_t *c, const uint8_t *params, uint8_t first,
                          uint8_t mode, const qcar_f32_t *m);
/* 0, or 1 + the index of the parameter to change (r_u) when a gain does not fit. */
uint8_t susp_ctrl_q_from_f32(susp_ctrl_q_t *q, const susp_ctrl_f32_t *c);

float susp_ctrl_step_f32(const susp_ctrl_f32_t *c, const susp_est_f32_t *e, uint8_t *status);
/* u in N, Q16. */
int32_t susp_ctrl_step_q(const susp_ctrl_q_t *c, const susp_est_q_t *e, uint8_t *status);

#endif
