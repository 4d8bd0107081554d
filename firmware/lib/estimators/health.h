/* The Kalman filters' health check, one mechanism for all of them (UIIEKF, KF-UI; the
 * Python twin is host/vehil/estimators/_health.py): the normalised innovation squared
 * (NIS) averaged over a window, and a state more than 3σ outside its plausible range.
 * Either sets STATUS_DIVERGED (docs/estimators/kfui.md, "Health"). */
#ifndef VEHIL_ESTIMATORS_HEALTH_H
#define VEHIL_ESTIMATORS_HEALTH_H

#include <stdint.h>

/* The NIS's exponential average with weight alpha = T / window (at most 1). */
static inline float health_nis_mean(float mean, float alpha, float nis)
{
    return mean + alpha * (nis - mean);
}

/* x more than 3σ (σ² = var) below lo or above hi. */
static inline uint8_t health_outside_3sigma(float x, float lo, float hi, float var)
{
    float out = x < lo ? x - lo : (x > hi ? x - hi : 0.0f);
    return out * out > 9.0f * var;
}

#endif
