/* Seed 003's extended state observer inside the quarter-car ECU (the paper's Sec. 4): two 3-state
 * observers (eq. 12) on the displacements the conditioning integrates, β = 3/ε, 3/ε², 1/ε³
 * (error poles at -1/ε), Euler at T; design 1: w = (1 - e^(-T/ε))/T for 1/ε, which puts the
 * Euler loop's own poles at e^(-T/ε). Variant A: no model inside (F̂ = z3, z6). Variant B:
 * the nominal strut's nonlinear terms inside, the rest left to z3, z6 (see eso.py).
 * x̂_r = x̂_us + (m_us F̂2 - f_s - f_d)/k_us, the strut force f_s + f_d from the nominal strut
 * at x̂ or (road_from) -m_s F̂1. Then the predictive controller.
 *
 * Inputs  a_s, a_us [m/s²] Q16.   Outputs see susp_ecu.h.
 * Params  T Q30, ε Q24, variant Q0, design Q0, road_from Q0, then the ECU tail (susp_ecu.h).
 * float32 (step_f32) and fixed point (step_q): z Q28 (m), Q24 (m/s), Q20 (m/s²); T and the
 * gains as factors (fx_factor_t) from the error's or the state's Q to the one they update. */
#ifndef VEHIL_ESTIMATORS_ESO_H
#define VEHIL_ESTIMATORS_ESO_H

#include <stdint.h>

#include "estimators/estimator.h"
#include "estimators/susp_ecu.h"

#define ESO_ID 40u

typedef struct {
    susp_ecu_f32_t ecu;
    float T, g[3]; /* T β1, T β2, T β3 (both observers share them) */
    float z[6];
    float fnl; /* variant B: the nonlinear strut force at z */
} eso_f32_t;

typedef struct {
    susp_ecu_q_t ecu;
    /* T (Q24 -> Q28 and Q20 -> Q24), then the gains g1, g2, g3 (Q28 -> Q28, Q24, Q20) */
    fx_xfactor_t k[4];
    int32_t z[6];          /* Q28 Q24 Q20, Q28 Q24 Q20 */
    int32_t acc[2];        /* this step's accelerations into the observers, Q20 */
    int32_t fnl;           /* N, Q16 */
    uint8_t model_in;      /* u - f_nl enters the observers (else acc is z3, z6 as they are) */
} eso_q_t;

typedef struct {
    uint8_t mode, variant, road_from;
    union {
        eso_f32_t f32;
        eso_q_t q;
    } u;
} eso_state_t;

enum { ESO_K_T, ESO_K_G1, ESO_K_G2, ESO_K_G3 }; /* eso_q_t's factors k */

/* The fixed-point step's front: both conditioning channels (a_s, a_us as the SAMPLE carries
 * them), then both observers' Euler steps (eq. 12) on s->acc (or z3, z6: model_in). On the
 * AVR an assembly routine (eso_avr.S with accel_cond_avr.S) that keeps the channels, z, e and
 * the sums in registers across the products; the C twin gives the same bits on the host.
 * Given out, the assembly does the variant-A rest of the step too (eso.c's back_q: the road
 * from the nominal strut or, road_from, from the body; the controller; the outputs). */
void eso_front_q_c(eso_q_t *s, const uint8_t *in, uint8_t *status);
#if defined(__AVR__)
void eso_front_q_avr(eso_q_t *s, const uint8_t *in, uint8_t *status, uint8_t *out,
                     uint8_t road_from);
#endif

extern const ROM estimator_t eso_estimator;

#endif
