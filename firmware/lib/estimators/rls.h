/* RLS with forgetting (seed 002's baseline, note §3): θ = [m, C_dA_f, m sin(ε + β_r)]
 * constant, λ = 0.95, on STLQF's regression (estimators/longit.h). Forgetting pauses
 * while a variance would pass p_cap times its start (windup guard); a P that round-off
 * made non-positive restarts at P(0), flagged SINGULAR.
 *
 * FIXED works in normalised units, so every quantity is O(1) in Q30 (P in Q27):
 * ψ_n = [v̇/8, ½ρv²/4096, g'/16], z_n = z/16384, θ_n = [m/2048, C_dA_f/4, m sin/1024]
 * (ψ_nᵀ θ_n = z_n exactly as ψᵀ θ = z); it needs v < 82 m/s, |v̇| < 16 m/s²,
 * |z| < 32 kN, m < 4096 kg, and takes no prefilter.
 *
 * Inputs  v [m/s] Q24, v̇ [m/s²] Q24, z [N] Q14.  Outputs m̂ [kg] Q16, Ĉ_dA_f [m²] Q16,
 * β̂_r [deg] Q20.  Params  λ, P(0) of m and m sin, P(0) of C_dA_f, p_cap, then longit's. */
#ifndef VEHIL_ESTIMATORS_RLS_H
#define VEHIL_ESTIMATORS_RLS_H

#include <stdint.h>

#include "estimators/estimator.h"
#include "estimators/longit.h"

#define RLS_ID 31u

typedef struct {
    longit_t model;
    uint8_t mode;
    float lambda, p0[3], cap[3]; /* cap: forgetting pauses while a variance would pass it */
    union {
        struct {
            float theta[3], P[9];
        } f32;
        struct {
            int32_t theta[3]; /* θ_n, Q30 */
            int32_t P[9];     /* Q27 */
            int32_t theta0[3];                         /* θ_n(0), Q30 */
            int32_t p0[3], cap[3], lambda, inv_lambda; /* Q27, Q30 */
            longit_q_t shared;
        } q;
    } u;
} rls_state_t;

extern const estimator_t rls_estimator;

#endif
