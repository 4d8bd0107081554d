/* Seed 003's EKF with an unknown input (KF-UI, the paper's Sec. 5) inside the quarter-car ECU,
 * float32. States [x_s, ẋ_s, x_us, ẋ_us], unknown input x_r by generalised least squares
 * each step (eqs. 26-33); y = [x_s, ẍ_s, x_us, ẍ_us] from the conditioned displacements
 * and the raw accelerations; printed forward-Euler prediction F = I + T J (eqs. 35-36).
 * Then the predictive controller. The update is eqs. 29-33 through an LDLᵀ factor of the
 * innovation covariance, which makes the unknown input the last decorrelated innovation
 * (docs/estimators/kfui.md).
 *
 * Inputs  a_s, a_us [m/s²].   Outputs see susp_ecu.h.
 * Params  T, q, r_x, r_a, p0, s0, nis_max, nis_window, x_max, then the ECU tail.
 * Health: DIVERGED when the windowed NIS passes nis_max, a variance is negative, or x̂_s,
 * x̂_us or x̂_r is more than 3σ outside ±x_max. */
#ifndef VEHIL_ESTIMATORS_KFUI_H
#define VEHIL_ESTIMATORS_KFUI_H

#include <stdint.h>

#include "estimators/estimator.h"
#include "estimators/susp_ecu.h"

#define KFUI_ID 41u

/* Per-step constants, set at CONFIG from T and the nominal model. */
typedef struct {
    float inv_m_s, inv_m_us, d1, inv_d1;   /* 1/m_s, 1/m_us, k_us/m_us, m_us/k_us */
    float T_m_s, T_m_us, T_d1;             /* T/m_s, T/m_us, T k_us/m_us */
    float k2_2, k3_3, c2_2;                /* 2 k2, 3 k3, 2 c2: the Jacobian's slopes */
    float dv_min;                          /* the damper's held rate, -inf: none */
} kfui_const_t;

typedef struct {
    susp_ecu_f32_t ecu;
    kfui_const_t c;
    float T, q, r_x, r_a, p0;
    float nis_max, alpha, x_max; /* health: alpha = T / nis_window */
    float x[4], P[4][4], d; /* x̂, P (kept exactly symmetric), û* = x̂_r */
    float var_d;            /* S: û*'s variance */
    float nis;              /* the NIS outside the road's direction, averaged */
} kfui_state_t;

extern const ROM estimator_t kfui_estimator;

#endif
