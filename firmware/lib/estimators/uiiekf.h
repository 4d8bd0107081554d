/* UIIEKF (seed 000, eqs. 34-37): iterated EKF on the single-track braking model with
 * the brake torque as an unknown input, float32. 5 states [v_x, v_y, r, ω_f, ω_r],
 * or the straight-line reduction [v_x, ω_f, ω_r] (docs/estimators/uiiekf.md). The
 * printed iteration (eq. 36, the same z applied N times) or one standard pass; the
 * analytic Jacobian; a health check that sets STATUS_DIVERGED.
 *
 * Inputs  ω_f, ω_r [rad/s].   Outputs v̂_x [m/s], d̂ (innovation along C B).
 * Params  T, n_states, iterations, form, c1, c2, c3 (the model's tires), p0, q_v, q_lat,
 *         q_w (densities per second), r_meas; the car: m, r_w, i_w, k_b, psi, h_cg, l_f,
 *         l_r; the health check: v_max, nis_max, v_min, nis_window; the car's i_z, rho,
 *         c_d, a_f, h_a, g. */
#ifndef VEHIL_ESTIMATORS_UIIEKF_H
#define VEHIL_ESTIMATORS_UIIEKF_H

#include <stdint.h>

#include "estimators/estimator.h"

#define UIIEKF_ID 21u
#define UIIEKF_MAX_STATES 5u

/* Set at CONFIG from the parameters: what a step multiplies by. */
typedef struct {
    float T, p0, q_v, q_lat, q_w, r_meas; /* q_* per step: the densities times T */
    float r_w, two_inv_m, two_inv_i_z, r_w_inv_i_w, l_f, l_r;
    float load_f, load_r, transfer, drag; /* static loads, m h / 2L, ½ ρ c_d A_f h_a / 2L */
    float psi_c1, c2, psi_c3, psi_c1c2, g0; /* Burckhardt: ψ c1, c2, ψ c3, ψ c1 c2, μ'(0) */
    float cb[2], inv_cb2;                   /* C B and 1 / |C B|² */
    float alpha, nis_max, v_max, v_max2, w_min, w_max; /* health: ..., v_min / R, v_max / R */
    uint8_t n, iterations, form;
} uiiekf_params_t;

typedef struct {
    uiiekf_params_t p;
    float x[UIIEKF_MAX_STATES];
    float P[UIIEKF_MAX_STATES][UIIEKF_MAX_STATES]; /* kept exactly symmetric */
    float d_x; /* the model's last acceleration, for the load transfer */
    float nis; /* the windowed mean of the innovation's χ²(1) */
    uint8_t started;
} uiiekf_state_t;

extern const ROM estimator_t uiiekf_estimator;

#endif
