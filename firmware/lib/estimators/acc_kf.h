/* ACC reference-speed Kalman filter (seed 004, CN101655504A, eqs. 1-8):
 * state [v_r, a_0], input a_m, measurement the mean non-driven wheel speed,
 * correction 1 (bias noise mean r̄·Δa_f) and correction 2 (C = [1 - s(k-1), 0]
 * while braking), each switchable. One filter in float32 (acc_kf_step_f32) and
 * in int32 fixed point (acc_kf_step_q), same shapes, same order.
 *
 * Inputs  a_m [m/s²] Q24, ω_l, ω_r [rad/s] Q16, brake [0/1] Q0.
 * Outputs v̂_r [m/s] Q16, â_0 [m/s²] Q24.
 * Params  T [s] Q30, r_w [m] Q24, n_v [(m/s)²/s] Q27, n_b [(m/s²)²/s] Q30, R [(m/s)²]
 *         Q24, p0_v Q24, p0_b Q30, r̄ Q30, corr1 Q0, corr2 Q0, v_guard [m/s] Q16,
 *         lpf_hz [Hz] Q24 (0: a_f = a_m), z2_max Q16, z_window [s] Q24, v_max [m/s]
 *         Q16, s_max Q30.
 * Health: DIVERGED when the innovation's mean over z_window, squared over the variance it
 * has when the innovations are white (S α / (2 - α), α = T / z_window), passes z2_max, or
 * v̂ is more than 3σ (σ² = P11) outside [-v_guard, v_max] (docs/estimators/acc_kf.md).
 * CONFIG derives the step's numbers from them and T: Q11 = n_v T, Q22 = n_b T and the
 * LPF's eq. 4b coefficients (a Butterworth at lpf_hz, lpf_hz T <= 0.4), so the step
 * itself sees per-step values only. */
#ifndef VEHIL_ESTIMATORS_ACC_KF_H
#define VEHIL_ESTIMATORS_ACC_KF_H

#include <stdint.h>

#include "estimators/estimator.h"
#include "fixmath/fixmath.h"

#define ACC_KF_ID 10u

typedef struct {
    float T, r_w_half, q_v, q_b, R, p0_v, p0_b, rbar, v_guard, s_max;
    float alpha, z_lim, v_max; /* health: T / z_window, z2_max α / (2 - α), ... */
    float b0, c[2];       /* eq. 4b: b = b0 (1, 2, 1) */
    uint8_t lpf_on;       /* lpf_hz > 0 (else a_f = a_m) */
} acc_kf_params_f32_t;

typedef struct {
    float v, a0;          /* x̂ */
    float p11, p12, p22;  /* P, symmetric */
    float u_prev, w2_prev, slip;
    float am[2], af[2];   /* a_m(k-1), a_m(k-2); a_f(k-1), a_f(k-2) */
    float e_mean;         /* the innovation e averaged over z_window */
} acc_kf_f32_t;

/* Fixed point: the Q format of each member is in its comment. */
typedef struct {
    int32_t T;            /* Q30 */
    fx_ufactor_t T_f;     /* T to 16 bits, and T_q28: T 2^-2 (T P22 from Q30 to Q28) */
    fx_ufactor_t T_q28;
    int32_t r_w_half;     /* Q28 (a byte-aligned product shift for v_m) */
    int32_t q_v;          /* Q28 */
    int32_t q_b;          /* Q30 */
    int32_t R;            /* Q24 */
    fx_ufactor_t R_f;     /* R 2^-7 to 16 bits */
    int32_t p0_v;         /* Q28 */
    int32_t p0_b;         /* Q30 */
    fx_factor_t rbar;     /* r̄ to 16 bits (eq. 6's Q24 -> Q24 product) */
    int32_t v_guard;      /* Q20 */
    int32_t s_max;        /* Q30 */
    fx_factor_t b4;       /* 4 b0 (b = b0 (1, 2, 1)) to 16 bits */
    fx_ufactor_t a2;      /* -c2 in (0, 1) to 16 bits */
    uint8_t lpf_on;       /* lpf_hz > 0 (else a_f = a_m) */
    uint32_t alpha;       /* Q24: T / z_window (>= 1e-6: within 3 % at that corner) */
    uint8_t e_shift;      /* 28 - q_e: ē from Q28 to the health check's Q q_e */
    uint32_t z_lim;       /* Q(2 q_e): R z2_max α / (2 - α) (m/s)² */
    int32_t v_max;        /* Q20 */
} acc_kf_params_q_t;

typedef struct {
    int32_t v;            /* Q20 */
    int32_t a0;           /* Q24 */
    int32_t p11, p12;     /* Q28 */
    int32_t p22;          /* Q30 */
    int32_t u_prev;       /* Q24 */
    int32_t w2_prev;      /* Q24 */
    int32_t slip;         /* Q30 */
    int32_t am4[2];       /* Q24: a_m(k-1) / 4, a_m(k-2) / 4, floored */
    int32_t af, daf;      /* Q24: a_f(k-1), and its increment a_f(k-1) - a_f(k-2) */
    fx_factor_t kv, ka;   /* the last gains k1 (Q20 -> Q20) and k2 2^4 (Q20 -> Q24) */
    uint16_t g16;         /* Q15: 1 - c k1 = R / S */
    int32_t e_mean;       /* Q28: the innovation averaged over z_window, e within ±8 m/s */
    uint8_t p_steady;     /* the last update, with c = 1, left P unchanged */
    uint8_t p_status;     /* the flags the last covariance update raised */
} acc_kf_q_t;

typedef struct {
    uint8_t mode, corr1, corr2, started;
    union {
        struct {
            acc_kf_params_f32_t p;
            acc_kf_f32_t s;
        } f32;
        struct {
            acc_kf_params_q_t p;
            acc_kf_q_t s;
        } q;
    } u;
} acc_kf_state_t;

extern const ROM estimator_t acc_kf_estimator;

#endif
