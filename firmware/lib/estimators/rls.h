/* RLS with forgetting (seed 002's baseline, note §3): θ = [m, C_dA_f, m sin(ε + β_r)]
 * constant, λ = 0.95, on STLQF's regression (estimators/longit.h).
 *
 * Inputs  v [m/s], v̇ [m/s²], z [N].  Outputs m̂ [kg], Ĉ_dA_f [m²], β̂_r [deg].
 * Forgetting pauses while a variance would pass p_cap times its start (windup guard).
 *
 * Params  λ, P(0) of m and m sin, P(0) of C_dA_f, p_cap, then longit's. float32. */
#ifndef VEHIL_ESTIMATORS_RLS_H
#define VEHIL_ESTIMATORS_RLS_H

#include <stdint.h>

#include "estimators/estimator.h"
#include "estimators/longit.h"

#define RLS_ID 31u

typedef struct {
    longit_t model;
    float lambda, p0_m, p0_cda, p_cap;
    float cap[3]; /* forgetting pauses while a variance would pass these */
    float theta[3];
    float P[9];
} rls_state_t;

extern const estimator_t rls_estimator;

#endif
