/* The longitudinal regression of seed 002 (eq. 24) that STLQF and RLS share:
 * m v̇ + C_dA_f ½ρv² + m sin(ε + β_r) g/cos ε = F_x, ψ = [v̇, ½ρv², g/cos ε],
 * θ = [m, C_dA_f, m sin(ε + β_r)]; optionally v̇, ½ρv² and z through the same
 * 2nd-order Butterworth low-pass (the host's stlqf.Prefilter). */
#ifndef VEHIL_ESTIMATORS_LONGIT_H
#define VEHIL_ESTIMATORS_LONGIT_H

#include <stdint.h>

#include "estimators/params.h"

/* The parameters both take last, in this order (host: stlqf.SHARED_PARAMS). */
enum {
    LONGIT_EPS,
    LONGIT_RHO,
    LONGIT_G,
    LONGIT_M0,
    LONGIT_CDA0,
    LONGIT_T,
    LONGIT_PREFILTER_HZ,
    LONGIT_N_PARAMS
};
extern const ROM param_range_t longit_ranges[LONGIT_N_PARAMS];

typedef struct {
    float eps, half_rho, g_cos; /* ε, ½ρ, g / cos ε */
    float m0, cda0, T;
    float b0, a1, a2;  /* prefilter (b1 = 2 b0, b2 = b0) */
    float s[3][2];     /* its states for v̇, ½ρv², z */
    uint8_t filter, started;
} longit_t;

/* FIXED's shared constants, computed from the Q parameters with integers only (libm's
 * last bit differs between avr-libc and the host, and FIXED must give the same bits). */
typedef struct {
    int32_t eps, sin_eps; /* ε, sin ε: Q30 */
    int32_t half_rho;     /* ½ρ: Q24 */
    int32_t g_cos;        /* g / cos ε: Q26 */
    int32_t m0;           /* Q16 */
    int32_t cda0;         /* Q24 */
} longit_q_t;

/* FIXED's input bounds, so every product of the fixed-point steps fits: |v| < 82 m/s
 * (½ρv² < 2^13 in Q18), |v̇| < 16 m/s², |z| < 65.5 kN: a 4 t vehicle (θ's range) at that
 * v̇. z's bound is below 2^30 in Q14 so that the difference of two stays in int32 (STLQF's
 * error filter); Q13 would double the z rounding that C_dA_f reads at crawling speed. */
#define LONGIT_V_MAX_Q24 ((int32_t)82 << 24)
#define LONGIT_VDOT_MAX_Q24 ((int32_t)16 << 24)
#define LONGIT_Z_MAX_Q14 (((int32_t)1 << 30) - 1)
#define LONGIT_V_MAX 82.0f
#define LONGIT_VDOT_MAX 16.0f
#define LONGIT_Z_MAX 65536.0f

/* 0 if the estimator's own n_own parameters and then the shared ones are in range,
 * else 1 + the index of the first bad one. FIXED takes no prefilter. */
uint8_t longit_check(const uint8_t *params, uint8_t mode, const param_range_t *own, uint8_t n_own);

/* Reads the shared parameters starting at index `first`, in either numeric mode. */
void longit_configure(longit_t *l, const uint8_t *params, uint8_t first, uint8_t mode);

/* The shared parameters, starting at index `first`, as FIXED's constants. */
void longit_configure_q(longit_q_t *l, const uint8_t *params, uint8_t first);

/* The number of bits of x (0 for 0): FIXED's block exponents in STLQF and RLS; inline, as
 * both call it in their steps' hot paths. */
static inline uint8_t longit_bit_length(uint32_t x)
{
    /* Whole words and bytes by moves, then the top byte one bit at a time as a byte: the
     * AVR shifts an int32 a bit at a time. */
    uint8_t n = 32;
    if (x >> 16 == 0u) {
        x <<= 16;
        n = 16;
    }
    if (x >> 24 == 0u) {
        x <<= 8;
        n = (uint8_t)(n - 8u);
    }
    uint8_t top = (uint8_t)(x >> 24);
    if (top == 0u) {
        return 0;
    }
    while (top < 0x80u) {
        top = (uint8_t)(top << 1);
        n--;
    }
    return n;
}

/* The prefilter back to its start (it settles on the next sample). */
void longit_reset(longit_t *l);

/* ψ and z from a SAMPLE's v, v̇, z, clamped to the bounds above (STATUS_CLAMPED, as
 * FIXED's), prefiltered; STATUS_NOT_FINITE (and nothing read) if one is not finite. */
uint8_t longit_inputs(longit_t *l, const uint8_t *in, float *psi, float *z);

/* STATUS_CLAMPED if a float32 SAMPLE lies past the bounds above, which no road vehicle
 * reaches: RLS does not learn from it in any mode, as FIXED cannot hold it. */
uint8_t longit_past_bounds(const uint8_t *in);

/* x = [v̇ Q24, ½ρv² Q18, z Q14] from a FIXED SAMPLE (v Q24, v̇ Q24, z Q14), clamped to the bounds above
 * (STATUS_CLAMPED into *status). */
void longit_inputs_q(const longit_q_t *l, const uint8_t *in, int32_t *x, uint8_t *status);

/* θ(0) = [m0, C_dA_f0, m0 sin ε] (a level road). */
void longit_initial(const longit_t *l, float *theta);

/* Writes m̂, Ĉ_dA_f and β̂_r = asin(θ3/θ1) - ε in degrees; returns STATUS_CLAMPED when
 * |θ3/θ1| > 1 or m̂ <= 0 (the grade is then clamped). */
uint8_t longit_outputs(const longit_t *l, float m, float cda, float m_sin, uint8_t *out);

/* FIXED's outputs: m̂ Q16, Ĉ_dA_f Q16 and β̂_r Q20 from m (Q q_m), C_dA_f (Q16) and
 * m sin(ε + β_r) (Q q_ms); STATUS_CLAMPED as longit_outputs. */
void longit_outputs_q(const longit_q_t *l, int32_t m, uint8_t q_m, int32_t cda, int32_t m_sin,
                      uint8_t q_ms, uint8_t *out, uint8_t *status);

/* The same from m̂ Q16, Ĉ_dA_f Q16 and θ3/θ1 in Q30 (the caller flags m̂ <= 0). */
void longit_outputs_ratio_q(const longit_q_t *l, int32_t m, int32_t cda, int32_t ratio,
                            uint8_t *out, uint8_t *status);

#endif
