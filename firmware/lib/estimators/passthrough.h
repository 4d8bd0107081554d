/* passthrough: returns its inputs unchanged. The zero-compute baseline for
 * latency profiles, and the estimator the link tests run through. */
#ifndef VEHIL_ESTIMATORS_PASSTHROUGH_H
#define VEHIL_ESTIMATORS_PASSTHROUGH_H

#include "estimators/estimator.h"

#define PASSTHROUGH_ID 0u

typedef struct {
    uint8_t unused; /* C99 forbids empty structs */
} passthrough_state_t;

extern const ROM estimator_t passthrough_estimator;

#endif
