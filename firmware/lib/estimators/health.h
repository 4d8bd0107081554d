/* The Kalman filters' health checks (the Python twin is host/vehil/estimators/_health.py):
 * an average over a window, of the normalised innovation squared (NIS: UIIEKF, KF-UI) or of
 * the innovation itself (ACC KF), and a state more than 3σ outside its plausible range.
 * Either sets STATUS_DIVERGED (docs/estimators/kfui.md, "Health"). */
#ifndef VEHIL_ESTIMATORS_HEALTH_H
#define VEHIL_ESTIMATORS_HEALTH_H

#include <stdint.h>

/* An exponential average with weight alpha = T / window (at most 1). */
static inline float health_window_mean(float mean, float alpha, float x)
{
    return mean + alpha * (x - mean);
}

/* x more than 3σ (σ² = var) below lo or above hi. */
static inline uint8_t health_outside_3sigma(float x, float lo, float hi, float var)
{
    float out = x < lo ? x - lo : (x > hi ? x - hi : 0.0f);
    return out * out > 9.0f * var;
}

#endif
