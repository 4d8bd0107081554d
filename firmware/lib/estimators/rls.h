/* RLS with forgetting (seed 002's baseline): θ = [m, C_dA_f, m sin(ε + β_r)]
 * constant, λ = 0.95, on STLQF's regression (estimators/longit.h). Forgetting pauses
 * while a variance would pass p_cap times its start (windup guard); a P that round-off
 * made non-positive restarts at P(0), flagged SINGULAR.
 *
 * FIXED (docs/estimators/rls.md) keeps θ in physical units (m, m sin Q16 kg, C_dA_f Q20
 * m², the innovation Q12 N) and P in floating point made of integers: P_ij = (λ / l)
 * P̃_ij 2^(e_i + e_j) with P̃ Q30, its diagonal kept in [1/4, 1) by the exponents, so
 * |P̃_ij| < 1 always, whatever the decades P spans (1e-7 when a direction is well
 * excited, p_cap · P(0) when it is not), and forgetting one multiply of the scalar l;
 * the regressor, the denominator and the gains get an exponent each per step. Every
 * multiply is fixmath's assembly kernel for its shift.
 * It needs v < 82 m/s, |v̇| < 16 m/s², |z| < 65.5 kN (longit.h) and takes no prefilter.
 *
 * ILL_CONDITIONED while a variance P_ii is above held_max P(0)_ii: the prior (or the
 * forgetting and the windup guard that hold P near it) carries that estimate more than the
 * data do (docs/estimators/rls.md).
 * Inputs  v [m/s] Q24, v̇ [m/s²] Q24, z [N] Q14.  Outputs m̂ [kg] Q16, Ĉ_dA_f [m²] Q16,
 * β̂_r [deg] Q20.  Params  λ, P(0) of m and m sin, P(0) of C_dA_f, p_cap, held_max, t_ref,
 * q_grade (θ3's random walk: P_33 grows by q_grade T a step, so the grade can move while λ
 * keeps a long memory of m and C_dA_f), then longit's. */
#ifndef VEHIL_ESTIMATORS_RLS_H
#define VEHIL_ESTIMATORS_RLS_H

#include <stdint.h>

#include "estimators/estimator.h"
#include "estimators/longit.h"
#include "fixmath/fixmath.h"

#define RLS_ID 31u

typedef struct {
    longit_t model;
    uint8_t mode;
    float lambda, p0[3], cap[3]; /* cap: forgetting pauses while a variance would pass it */
    float held[3];               /* ILL_CONDITIONED while a variance is above held_max P(0) */
    float walk;                  /* θ3's random walk: q_grade T added to P_33 a step */
    union {
        struct {
            float theta[3], P[9];
        } f32;
        struct {
            int32_t theta[3];          /* m Q16, C_dA_f Q20, m sin Q16 */
            int32_t P[6];              /* P̃ 00 10 11 20 21 22, Q30 */
            int8_t e[3];               /* P_ij = P̃_ij 2^(e_i + e_j) */
            int32_t p0[3], cap[3];     /* P(0)_ii and p_cap P(0)_ii as P̃ (Q30) */
            int32_t held[3];           /* held_max P(0)_ii / λ as P̃ (Q30) */
            int8_t e_p0[3], e_cap[3], e_held[3]; /* with these exponents */
            int32_t lambda, l;         /* λ and l, Q30: l in [1/4, 1] */
            uint16_t walk;             /* q_grade T / λ as P̃ to 16 bits (Q15), 0 for none */
            int8_t e_walk;             /* with this exponent */
            fx_ufactor_t g_cos;        /* g / cos ε to 16 bits for the innovation (Q26 / 2^30) */
            longit_q_t shared;
        } q;
    } u;
} rls_state_t;

extern const ROM estimator_t rls_estimator;

#endif
