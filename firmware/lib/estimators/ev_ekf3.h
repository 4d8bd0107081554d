/* The board's reduced EKF for seed 001 (the 7-state EKF and UKF do not keep a 10 ms step
 * on the ATmega2560): x = [v_x, v_y, γ], the lateral forces not states but the
 * quasi-static combined-slip ones of ev_model at the estimate (no relaxation, eq. 20
 * at steady state). One tire evaluation per step, at the predicted state: the next
 * prediction reuses its slopes and its forces carried to the corrected state to first
 * order (the forces out too). Same inputs and outputs as ev_ekf, and its parameters but the
 * force states' (p0_f, q_f), then `tires`: 1 takes the tires' linear range (ev_wheels),
 * which with a fixed R keeps a 10 ms step. Host: estimators/upf.py (Ekf3). */
#ifndef VEHIL_ESTIMATORS_EV_EKF3_H
#define VEHIL_ESTIMATORS_EV_EKF3_H

#include <stdint.h>

#include "estimators/estimator.h"
#include "estimators/ev_model.h"

#define EV_EKF3_ID 52u

typedef struct {
    ev_model_t model;
    ev_drive_t dr_prev; /* what the prediction takes of the last sample's inputs */
    float x[3];
    float P[9];
    float fy[4];    /* the lateral forces at x */
    ev_slopes_t d;  /* the slopes at the last update's predicted state */
    float J[9];     /* and the accelerations' slopes through the forces there */
    uint8_t started;
} ev_ekf3_state_t;

extern const ROM estimator_t ev_ekf3_estimator;

#endif
