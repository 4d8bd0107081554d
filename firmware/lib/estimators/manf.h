/* MANF (seed 000, eqs. 39-44 as docs/estimators/manf.md reads them): vehicle speed
 * during braking from wheel speed alone.
 * v̂ -= T R_g tanh(v̂ - R ω) (corrected sign, reading B; switches for the printed
 * sign and reading A), R_g ×γ on a kept error sign, ×ξ on a flip, in [0, a];
 * |Δv̂| <= a T. float32 (manf_step_f32) and fixed point (manf_step_q).
 *
 * Inputs  ω_f, ω_r [rad/s] Q16.   Outputs v̂ [m/s] Q16, R_g [m/s²] Q24.
 * Params  T Q30, r_w Q24, wheel Q0, γ Q30, ξ Q30, R_g(0) Q24, a Q24, printed_sign Q0,
 *         reading Q0, t_ref Q30 (0: γ, ξ per sample; > 0: per t_ref, rate-normalised),
 *         e_db Q24 (errors within ±e_db carry no sign for the adaptation). Fixed point: tanh from fx_tanh, |error| <= 7e-4. */
#ifndef VEHIL_ESTIMATORS_MANF_H
#define VEHIL_ESTIMATORS_MANF_H

#include <stdint.h>

#include "estimators/estimator.h"
#include "fixmath/fixmath.h"

#define MANF_ID 20u

typedef struct {
    float T, r_w, gamma, xi, rg0, a;
    float e_db; /* errors within ±e_db carry no sign */
    float limit; /* a T: the largest step of v̂ (eq. 43) */
} manf_params_f32_t;

typedef struct {
    float v, rg;
} manf_f32_t;

typedef struct {
    /* Q24, so that every product of the step shifts by whole bytes (fx_umul_q24), see
     * docs/estimators/manf.md */
    uint32_t gamma_m1, one_m_xi; /* γ - 1, 1 - ξ */
    uint32_t t_tanh[65];         /* T tanh(k / 16), k = 0..64, Q23: reading B's step */
    uint8_t xi_zero;             /* ξ = 0: a flip zeroes R_g */
    int32_t r_w;    /* Q24 */
    int32_t rg0;    /* Q24 */
    int32_t a;      /* Q24 */
    int32_t e_db;   /* Q24: errors within ±e_db carry no sign */
    int32_t limit;  /* a T, Q24: the largest step of v̂ (eq. 43) */
} manf_params_q_t;

typedef struct {
    int32_t v;      /* Q24 */
    int32_t rg;     /* Q24 */
} manf_q_t;

typedef struct {
    uint8_t mode, wheel, printed_sign, reading, started;
    int8_t s_prev; /* sign of the last non-zero error */
    union {
        struct {
            manf_params_f32_t p;
            manf_f32_t s;
        } f32;
        struct {
            manf_params_q_t p;
            manf_q_t s;
        } q;
    } u;
} manf_state_t;

extern const ROM estimator_t manf_estimator;

#endif
