/* The board's reduced EKF for seed 001 (the 7-state EKF and UKF do not keep a 10 ms step
 * on the ATmega2560): x = [v_x, v_y, γ], the lateral forces not states but the
 * quasi-static combined-slip ones of ev_model at the estimate (no relaxation, eq. 20
 * at steady state). Same inputs, outputs and parameters as ev_ekf (p0_f and q_f unused:
 * no force states); the forces out are linearised from the predicted state to the
 * corrected one. Host: estimators/upf.py (Ekf3). */
#ifndef VEHIL_ESTIMATORS_EV_EKF3_H
#define VEHIL_ESTIMATORS_EV_EKF3_H

#include <stdint.h>

#include "estimators/estimator.h"
#include "estimators/ev_model.h"

#define EV_EKF3_ID 52u

typedef struct {
    ev_model_t model;
    ev_inputs_t u_prev;
    float x[3];
    float P[9];
    float fy[4];
    uint8_t started;
} ev_ekf3_state_t;

extern const estimator_t ev_ekf3_estimator;

#endif
