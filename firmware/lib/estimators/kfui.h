/* Seed 003's EKF with an unknown input (KF-UI, note §1.5) inside the quarter-car ECU,
 * float32. States [x_s, ẋ_s, x_us, ẋ_us], unknown input x_r by generalised least squares
 * each step (eqs. 26-33); y = [x_s, ẍ_s, x_us, ẍ_us] from the conditioned displacements
 * and the raw accelerations; printed forward-Euler prediction F = I + T J (eqs. 35-36).
 * Then the predictive controller.
 *
 * Inputs  a_s, a_us [m/s²].   Outputs see susp_ecu.h.
 * Params  T, integrator (0 only: Euler), q, r_x, r_a, p0, s0, then the ECU tail. */
#ifndef VEHIL_ESTIMATORS_KFUI_H
#define VEHIL_ESTIMATORS_KFUI_H

#include <stdint.h>

#include "estimators/estimator.h"
#include "estimators/susp_ecu.h"

#define KFUI_ID 41u

typedef struct {
    susp_ecu_f32_t ecu;
    float T, q, r[4], p0;
    float x[4], P[16], d; /* x̂, P, û* = x̂_r */
    float Pb[16], H[16], PHt[16], Sig[16], K[16]; /* work */
} kfui_state_t;

extern const estimator_t kfui_estimator;

#endif
