/* Seed 001's distributed-drive EV model that ev_ekf, ev_ekf3 and ev_ukf share, float32
 * (host: host/vehil/models/ev4wd.py; the parameters: docs/estimators/ev.md).
 * x = [v_x, v_y, γ, F̃_1y..F̃_4y] (wheels FL, FR, RL, RR); u = δ, F_ix, F_z,i;
 * y = [a_x, a_y, γ, ω_1..ω_4]. ẋ from note eqs. (1)-(7), (20); y from (5), (29).
 *
 * Inputs  a_x, a_y [m/s²], γ [rad/s], ω_1..ω_4 [rad/s], δ [rad], T_1..T_4 [N·m].
 * Outputs v_x, v_y [m/s], γ [rad/s], F_1y..F_4y [N], β [deg].
 * Params  T, μ, v_x0, P0 (2), Q (3), fixed R (4), adaptive, c/d of (66)-(69) (15), r_clip,
 *         the car (24: ev_car_t); the 7-state filters then P0 and Q of the lateral forces
 *         (EV_FORCE_RANGES). */
#ifndef VEHIL_ESTIMATORS_EV_MODEL_H
#define VEHIL_ESTIMATORS_EV_MODEL_H

#include <stdint.h>

#include "estimators/params.h"

#define EV_NX 7u
#define EV_NY 7u
#define EV_N_INPUTS 12u
#define EV_N_OUTPUTS 8u

/* The parameters every filter takes first, in the host's order (ev.PARAMS). */
enum {
    EV_P_T, EV_P_MU, EV_P_VX0, EV_P_P0V, EV_P_P0LAT, EV_P_QV, EV_P_QVY, EV_P_QR,
    EV_P_RAX, EV_P_RAY, EV_P_RGZ, EV_P_RW, EV_P_ADAPTIVE,
    EV_P_CAX, EV_P_DAX1, EV_P_DAX2, EV_P_DAX3, EV_P_CAY, EV_P_DAY1, EV_P_DAY2,
    EV_P_CGZ, EV_P_DGZ1, EV_P_DGZ2, EV_P_CW, EV_P_DW1, EV_P_DW2, EV_P_DW3, EV_P_RCLIP,
    EV_N_TUNING,
    /* the car (ev.CAR_PARAMS) */
    EV_P_M = EV_N_TUNING, EV_P_IZ, EV_P_LF, EV_P_LR, EV_P_TRACK, EV_P_HCG, EV_P_RWHEEL, EV_P_IW,
    EV_P_RHO, EV_P_CD, EV_P_AF, EV_P_FROLL, EV_P_G, EV_P_BX, EV_P_CX, EV_P_BY, EV_P_CY,
    EV_P_EY, EV_P_BXA, EV_P_CXA, EV_P_BYK, EV_P_CYK, EV_P_SIGMA, EV_P_TAU_WDOT,
    EV_N_PARAMS
};

/* The 7-state filters' own first ones (ev.FORCE_PARAMS): p0_f and q_f, the lateral
 * forces' P0 and Q, with these ranges. */
enum { EV_PF_P0F, EV_PF_QF, EV_N_FORCE_PARAMS };
#define EV_FORCE_RANGES {1.0f, 1e8f, 16}, {1e-3f, 1e7f, 16}

/* What the body rates take of a sample's inputs (ev_ekf3 keeps only this for its
 * prediction). */
typedef struct {
    float cd, sd;  /* the front steer angle's cosine and sine */
    float fx[4];   /* F_ix (21) */
} ev_drive_t;

typedef struct {
    float delta;   /* front steer angle */
    ev_drive_t dr;
    /* ∂v_ix/∂(v_x, v_y, γ) and ∂v_iy/∂(v_x, v_y, γ): δ's alone, so once per sample */
    float L[4][3], dviy[4][3];
    float fz[4];   /* F_z,i from the measured a_x, a_y */
    float y[EV_NY];
} ev_inputs_t;

/* The car as the model uses it, derived from its parameters at CONFIG in the order the
 * constants were folded before they were parameters (the same float32 bits): divisions
 * cost ~490 cycles each on the chip, so the constant ones are reciprocals here. */
typedef struct {
    float m, inv_m, i_z, inv_iz, lr_iz; /* m, 1/m, I_z, 1/I_z, l_r / I_z */
    float lx[4], byw[4];                /* wheel centres r_i = (l_i, b_i), left + */
    float i_w, inv_r;                   /* I_w, 1 / R */
    float drag, drag2, roll;            /* ½ ρ C_d A, twice that, m g f */
    /* F_z,i = static ∓ a_x lon ∓ a_y lat (ours: the paper has none):
     * m g l_r / 2L, m g l_f / 2L, m h / 2L, m h l_r / (d L), m h l_f / (d L) */
    float fz_front, fz_rear, fz_lon, fz_lat_f, fz_lat_r;
    float bx_cx, by, cy, by_cy, ey, bxa, cxa, byk, cyk, sigma;
    uint8_t shape; /* EV_TIRE_*: which tire terms leave the defaults' short forms */
} ev_car_t;

/* The tire terms that take their general form (ev_wheels, ev_slopes): B_xα ≠ B_y (G_xα's
 * B_xα α is not B_y α), C_xα ≠ 1, E_y ≠ 0, C_yκ ≠ 1. Each costs an atan or more a wheel. */
#define EV_TIRE_BXA 1u
#define EV_TIRE_CXA 2u
#define EV_TIRE_EY 4u
#define EV_TIRE_CYK 8u

typedef struct {
    float T, inv_T, mu, lp; /* lp: the ω̇ low-pass's T / (τ + T) */
    float p[EV_N_TUNING];
    ev_car_t car;
    /* (66)-(69)'s c_j r_j / n_j and the clip bounds of a_x, a_y, γ, ω_i, set with the
     * parameters: divisions cost 486 cycles each on the chip */
    float r_scale[4], r_lo[4], r_hi[4];
    float w_prev[4], w_dot[4];
    uint8_t have_w, adaptive;
    uint8_t linear; /* linear tires (ev_ekf3's `tires` = 1), see ev_wheels */
} ev_model_t;

/* Per-wheel terms at one state; every model function below takes them, so a filter
 * evaluates the tires once per linearisation point or sigma point. */
typedef struct {
    float vix[4], alpha[4], fy_qs[4], kappa[4];
    /* for the slopes: max(|v_ix|, 0.5), tan α's magnitude v_iy / that, B_y α,
     * C_y atan(B_y α), its sine and G_yκ */
    float den[4], zz[4], ba[4], ty[4], sty[4], g_yk[4];
} ev_wheels_t;

/* Their slopes: ∂α_i/∂(v_x, v_y, γ), dκ̂_i/dα_i and dF_y,qs,i/dα_i (κ̂'s α-dependence in). */
typedef struct {
    float dalpha[4][3], dk[4], dqs[4];
} ev_slopes_t;

/* 0 if the n = EV_N_PARAMS + n_own parameters are in range (own ones after the shared),
 * else 1 + the first bad index. Stores them and resets the input filter. */
uint8_t ev_model_configure(ev_model_t *m, uint8_t mode, const uint8_t *params,
                           const param_range_t *own, uint8_t n_own);
void ev_model_reset(ev_model_t *m);

/* A SAMPLE's sensors into u (F_ix needs ω̇, so this advances the ω̇ filter);
 * STATUS_NOT_FINITE and nothing changed if one is not finite. */
uint8_t ev_model_inputs(ev_model_t *m, const uint8_t *in, ev_inputs_t *u);

/* With m->linear, the tires' linear range: α = -v_iy / max(|v_ix|, 0.5), F_y = B_y C_y μF_z α
 * and κ̂ = F_x / (B_x C_x μF_z), no combined-slip weights: no atan, sin or square root. */
void ev_wheels(const float *x, const ev_inputs_t *u, const ev_model_t *m, ev_wheels_t *w);
void ev_slopes(const ev_inputs_t *u, const ev_model_t *m, const ev_wheels_t *w, ev_slopes_t *d);
/* v̇_x, v̇_y, γ̇ (eqs. 1-7) with the tire-frame lateral forces fy: the 7-state model's
 * F̃_iy (x + 3) or the 3-state model's quasi-static ones (w->fy_qs). */
void ev_body_rates(const ev_model_t *m, const float *x, const float *fy, const ev_drive_t *dr,
                   float *rates);
/* 7 states: x + T ẋ, in place (w at x). */
void ev_step(const ev_model_t *m, float *x, const ev_inputs_t *u, const ev_wheels_t *w);
/* y = h(x) with lateral forces fy (as for ev_body_rates). */
void ev_h(const ev_model_t *m, const float *x, const float *fy, const ev_inputs_t *u,
          const ev_wheels_t *w, float *y);
/* 7 states: F = I + T ∂f/∂x and H = ∂h/∂x (row-major 7×7), analytic as on the host;
 * either may be NULL. */
void ev_jacobians(const ev_model_t *m, const float *x, const ev_inputs_t *u,
                  const ev_wheels_t *w, const ev_slopes_t *d, float *F, float *H);
/* 3 states (lateral forces quasi-static): J = ∂(v̇_x, v̇_y, γ̇)/∂(v_x, v_y, γ) through the
 * forces' slopes alone (3×3), which a prediction with the same u and d reuses. */
void ev_force_slopes3(const ev_model_t *m, const ev_inputs_t *u, const ev_slopes_t *d, float *J);
/* F = I + T (J + the rest of ∂f/∂x) (3×3). */
void ev_f3(const ev_model_t *m, const float *x, const float *J, float *F);
/* H (7×3) at x with w, d and J at x. */
void ev_h3(const ev_model_t *m, const float *x, const ev_inputs_t *u, const ev_wheels_t *w,
           const ev_slopes_t *d, const float *J, float *H);
/* diag R, fixed or by (66)-(69) with κ̂ at the estimate (w). */
void ev_noise(const ev_model_t *m, const ev_inputs_t *u, const ev_wheels_t *w, float *r);
/* The prior of n states (3, or EV_NX with each lateral force's variance p0_f): x, P (n×n). */
void ev_prior(const ev_model_t *m, uint8_t n, float p0_f, float *x, float *P);
/* EKF correction with y_j one at a time (R diagonal, so this is the batch update at the
 * predicted x): x (n), P (n×n, symmetric, and kept so exactly), H (EV_NY×n), innovations
 * e = y - h(x_pred), r = diag R. */
void ev_ekf_correct(float *x, float *P, uint8_t n, const float *H, const float *e,
                    const float *r);
/* P = (P + Pᵀ) / 2, against round-off. */
void ev_symmetrize(float *P, uint8_t n);
/* Writes v_x, v_y, γ, the lateral forces fy and β; STATUS_NOT_FINITE if one is not finite. */
uint8_t ev_outputs(const float *x, const float *fy, uint8_t *out);

#endif
