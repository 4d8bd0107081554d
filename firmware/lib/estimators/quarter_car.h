/* Seed 003's nominal quarter car (the paper's Sec. 3, Table 1), shared by the ESO, the KF-UI and
 * the suspension controller: the strut force f_s + f_d (eq. 2, literal square damper)
 * in float32 and in fixed point, and the model parameters read from CONFIG.
 * Params (8, in this order): m_s Q16, m_us Q16, k1 Q8, k2 Q8, k3 Q8, c1 Q16, c2 Q16, k_us Q8. */
#ifndef VEHIL_ESTIMATORS_QUARTER_CAR_H
#define VEHIL_ESTIMATORS_QUARTER_CAR_H

#include <stdint.h>

#include "estimators/params.h"
#include "fixmath/fixmath.h"

#define QCAR_N_PARAMS 8u

typedef struct {
    float m_s, m_us, k1, k2, k3, c1, c2, k_us;
} qcar_f32_t;

/* Fixed point: the strut's nonlinear terms k2 (Q8, N/m²), k3 and c2 as factors (fx_factor_t)
 * from Δx Q28 to Q8 and from Δẋ² Q24 to N Q16; the masses as 1/m from N Q16 to m/s² Q20;
 * the tire's equation over k_us: m_us/k_us, m_s/k_us as factors from F̂ Q20 to metres Q28,
 * and the whole strut over k_us (qcar_strut_over_kus_q): the spring's k1, k2, k3 over k_us
 * in Q20 (at most 100, 500 and 800 over the parameters' ranges: ±2,048), the damper's c1,
 * c2 over k_us in Q24 and Q28 (at most 2 s and 2 s²/m). */
typedef struct {
    int32_t k2;
    fx_factor_t k3, c2, inv_m_s, inv_m_us;
    fx_factor_t r_m_us, r_m_s;
    int32_t s1, s2, s3; /* k1/k_us, k2/k_us (1/m), k3/k_us (1/m²), Q20 */
    int32_t d1, d2;     /* c1/k_us (s) Q24, c2/k_us (s²/m) Q28 */
} qcar_q_t;

extern const ROM param_range_t qcar_ranges[QCAR_N_PARAMS];

/* The model from CONFIG's values starting at parameter `first`. */
void qcar_read_f32(qcar_f32_t *m, const uint8_t *params, uint8_t first, uint8_t mode);
void qcar_q_from_f32(qcar_q_t *q, const qcar_f32_t *m, uint8_t *status);

/* f_s + f_d at deflection dx, rate dv (eq. 2); `nonlinear_only` leaves out k1 dx + c1 dv. */
float qcar_strut_f32(const qcar_f32_t *m, float dx, float dv, uint8_t nonlinear_only);
/* k2 Δx² + k3 Δx³ + c2 Δẋ² in fixed point: dx Q28 (m), dv Q24 (m/s) -> N Q16. */
int32_t qcar_strut_nl_q(const qcar_q_t *m, int32_t dx, int32_t dv, uint8_t *status);
/* (f_s + f_d)/k_us, the whole strut over the tire's rate, in metres Q28: the spring and
 * the damper by Horner's rule on Δx to 24 bits (Q23, ±1 m) and Δẋ to 16 (Q12, ±8 m/s); Δx
 * or Δẋ past those ranges saturates (flagged). On the AVR an assembly routine
 * (quarter_car_avr.S); the C twin gives the same bits on the host. */
int32_t qcar_strut_over_kus_q_c(const qcar_q_t *m, int32_t dx, int32_t dv, uint8_t *status);
#if defined(__AVR__)
int32_t qcar_strut_over_kus_avr(const qcar_q_t *m, int32_t dx, int32_t dv, uint8_t *status);
#define qcar_strut_over_kus_q qcar_strut_over_kus_avr
#else
#define qcar_strut_over_kus_q qcar_strut_over_kus_q_c
#endif

#endif
