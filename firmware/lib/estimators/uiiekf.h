/* UIIEKF (seed 000, note §2.3): iterated EKF on the single-track braking model with
 * the brake torque as an unknown input, float32. 5 states [v_x, v_y, r, ω_f, ω_r],
 * or the straight-line reduction [v_x, ω_f, ω_r] (note §1.6). The printed
 * iteration (eq. 36, the same z applied N times) or one standard pass.
 *
 * Inputs  ω_f, ω_r [rad/s].   Outputs v̂_x [m/s], d̂ (innovation along C B).
 * Params  T, n_states, iterations, form, surface, p0, q_v, q_lat, q_w, r_meas. */
#ifndef VEHIL_ESTIMATORS_UIIEKF_H
#define VEHIL_ESTIMATORS_UIIEKF_H

#include <stdint.h>

#include "estimators/estimator.h"

#define UIIEKF_ID 21u
#define UIIEKF_MAX_STATES 5u

typedef struct {
    float T, p0, q_v, q_lat, q_w, r_meas;
    float tire[3]; /* Burckhardt c1, c2, c3 of the model's surface */
    uint8_t n, iterations, form;
} uiiekf_params_t;

typedef struct {
    uiiekf_params_t p;
    float x[UIIEKF_MAX_STATES];
    float P[UIIEKF_MAX_STATES * UIIEKF_MAX_STATES];
    float J[UIIEKF_MAX_STATES * UIIEKF_MAX_STATES];
    float tmp[UIIEKF_MAX_STATES * UIIEKF_MAX_STATES];
    float d_x; /* the model's last acceleration, for the load transfer */
    uint8_t started;
} uiiekf_state_t;

extern const estimator_t uiiekf_estimator;

#endif
