/* UKF on seed 001's 7-state EV model (ev_model.h), float32: additive noise, 15
 * sigma points from Cholesky, drawn again for the measurement, means as χ_0 +
 * Σ W_j (χ_j - χ_0); R fixed or adaptive (note eqs. 66-69). Parameters after
 * ev_model's: the force states' (EV_FORCE_RANGES), then the UT α (β = 2, κ = 0).
 * Host: estimators/upf.py (Ukf). */
#ifndef VEHIL_ESTIMATORS_EV_UKF_H
#define VEHIL_ESTIMATORS_EV_UKF_H

#include <stdint.h>

#include "estimators/estimator.h"
#include "estimators/ev_model.h"

#define EV_UKF_ID 51u
#define EV_UKF_NS (2u * EV_NX + 1u)

typedef struct {
    ev_model_t model;
    ev_inputs_t u_prev;
    float spread, wm0, wc0, w1; /* √(n + λ) and the weights (w1 for j > 0) */
    float p0_f, q_f;            /* the force states' P0 and Q */
    float x[EV_NX];
    float P[EV_NX * EV_NX];
    float chi[EV_UKF_NS][EV_NX];
    float Y[EV_UKF_NS][EV_NY];
    float S[EV_NY * EV_NY]; /* P_yy, then its inverse */
    float C[EV_NX * EV_NY]; /* P_xy, then the gain */
    uint8_t started;
} ev_ukf_state_t;

extern const ROM estimator_t ev_ukf_estimator;

#endif
