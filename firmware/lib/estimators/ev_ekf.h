/* EKF on seed 001's 7-state EV model (ev_model.h), float32: analytic Jacobians,
 * P = F P Fᵀ + Q, then the seven measurements as sequential scalar updates (R is
 * diagonal, fixed or adaptive by note eqs. 66-69). Host: estimators/upf.py (Ekf). */
#ifndef VEHIL_ESTIMATORS_EV_EKF_H
#define VEHIL_ESTIMATORS_EV_EKF_H

#include <stdint.h>

#include "estimators/estimator.h"
#include "estimators/ev_model.h"

#define EV_EKF_ID 50u

typedef struct {
    ev_model_t model;
    ev_inputs_t u_prev;
    float x[EV_NX];
    float P[EV_NX * EV_NX];
    float F[EV_NX * EV_NX]; /* the Jacobian F, then H */
    float tmp[EV_NX * EV_NX];
    float p0_f, q_f; /* the force states' P0 and Q */
    uint8_t started;
} ev_ekf_state_t;

extern const ROM estimator_t ev_ekf_estimator;

#endif
