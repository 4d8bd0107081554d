/* Seed 001's distributed-drive EV model that ev_ekf and ev_ukf share, float32
 * (host: estimators/_ev4wd_model.py, which lists each constant's source).
 * x = [v_x, v_y, γ, F̃_1y..F̃_4y] (wheels FL, FR, RL, RR); u = δ, F_ix, F_z,i;
 * y = [a_x, a_y, γ, ω_1..ω_4]. ẋ from note eqs. (1)-(7), (20); y from (5), (29).
 *
 * Inputs  a_x, a_y [m/s²], γ [rad/s], ω_1..ω_4 [rad/s], δ [rad], T_1..T_4 [N·m].
 * Outputs v_x, v_y [m/s], γ [rad/s], F_1y..F_4y [N], β [deg].
 * Params  T, μ, v_x0, P0 (3), Q (4), fixed R (4), adaptive, c/d of (66)-(69) (15), r_clip. */
#ifndef VEHIL_ESTIMATORS_EV_MODEL_H
#define VEHIL_ESTIMATORS_EV_MODEL_H

#include <stdint.h>

#include "estimators/params.h"

#define EV_NX 7u
#define EV_NY 7u
#define EV_N_INPUTS 12u
#define EV_N_OUTPUTS 8u

/* The parameters both filters take first, in the host's order (ev.PARAMS). */
enum {
    EV_P_T, EV_P_MU, EV_P_VX0, EV_P_P0V, EV_P_P0LAT, EV_P_P0F, EV_P_QV, EV_P_QVY, EV_P_QR, EV_P_QF,
    EV_P_RAX, EV_P_RAY, EV_P_RGZ, EV_P_RW, EV_P_ADAPTIVE,
    EV_P_CAX, EV_P_DAX1, EV_P_DAX2, EV_P_DAX3, EV_P_CAY, EV_P_DAY1, EV_P_DAY2,
    EV_P_CGZ, EV_P_DGZ1, EV_P_DGZ2, EV_P_CW, EV_P_DW1, EV_P_DW2, EV_P_DW3, EV_P_RCLIP,
    EV_N_PARAMS
};

typedef struct {
    float delta;   /* front steer angle */
    float cd, sd;  /* its cosine and sine */
    float fx[4];   /* F_ix (21) */
    float fz[4];   /* F_z,i from the measured a_x, a_y */
    float y[EV_NY];
} ev_inputs_t;

typedef struct {
    float T, mu, lp; /* lp: the ω̇ low-pass's T / (τ + T) */
    float p[EV_N_PARAMS];
    float w_prev[4], w_dot[4];
    uint8_t have_w, adaptive;
} ev_model_t;

/* Per-wheel terms at one state. */
typedef struct {
    float vix[4], alpha[4], fy_qs[4], kappa[4];
} ev_wheels_t;

/* 0 if the n = EV_N_PARAMS + n_own parameters are in range (own ones after the shared),
 * else 1 + the first bad index. Stores them and resets the input filter. */
uint8_t ev_model_configure(ev_model_t *m, uint8_t mode, const uint8_t *params,
                           const param_range_t *own, uint8_t n_own);
void ev_model_reset(ev_model_t *m);

/* A SAMPLE's sensors into u (F_ix needs ω̇, so this advances the ω̇ filter);
 * STATUS_NOT_FINITE and nothing changed if one is not finite. */
uint8_t ev_model_inputs(ev_model_t *m, const uint8_t *in, ev_inputs_t *u);

void ev_wheels(const float *x, const ev_inputs_t *u, float mu, ev_wheels_t *w);
/* x + T ẋ, in place. */
void ev_step(const ev_model_t *m, float *x, const ev_inputs_t *u);
void ev_h(const ev_model_t *m, const float *x, const ev_inputs_t *u, float *y);
/* F = I + T ∂f/∂x and H = ∂h/∂x, analytic as on the host; either may be NULL. */
void ev_jacobians(const ev_model_t *m, const float *x, const ev_inputs_t *u, float *F, float *H);
/* diag R, fixed or by (66)-(69) with κ̂ at x. */
void ev_noise(const ev_model_t *m, const float *x, const ev_inputs_t *u, float *r);
void ev_prior(const ev_model_t *m, float *x, float *P);
/* Writes x and β; STATUS_NOT_FINITE if one is not finite. */
uint8_t ev_outputs(const float *x, uint8_t *out);

#endif
