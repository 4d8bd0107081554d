/* ANF (seed 000's baseline, the filter MANF modifies; docs/estimators/manf.md, "ANF"):
 * vehicle speed during braking from wheel speed alone, v̂ -= T R_g sgn(v̂ - R ω) with a
 * fixed gain R_g (an acceleration, MANF's reading B), working sign. v̂(0) = R ω(0).
 * float32 and fixed point (the same law: the step T R_g is fixed at CONFIG).
 *
 * Inputs  ω_f, ω_r [rad/s] Q16.   Outputs v̂ [m/s] Q16.
 * Params  T Q30, r_w Q24, wheel Q0, R_g Q24. */
#ifndef VEHIL_ESTIMATORS_ANF_H
#define VEHIL_ESTIMATORS_ANF_H

#include <stdint.h>

#include "estimators/estimator.h"

#define ANF_ID 22u

typedef struct {
    uint8_t mode, wheel, started;
    union {
        struct {
            float r_w, step; /* step = T R_g [m/s] */
            float v;
        } f32;
        struct {
            int32_t r_w;  /* Q24 */
            int32_t step; /* T R_g, Q24 [m/s] */
            int32_t v;    /* Q24 [m/s] */
        } q;
    } u;
} anf_state_t;

extern const ROM estimator_t anf_estimator;

#endif
