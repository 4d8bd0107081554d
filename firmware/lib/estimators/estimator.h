/* The interface every estimator implements, and the registry the dispatcher
 * looks estimators up in. Inputs, outputs and parameters are arrays of 4-byte
 * values in the configured numeric mode's format (float32 or int32 Q). */
#ifndef VEHIL_ESTIMATORS_ESTIMATOR_H
#define VEHIL_ESTIMATORS_ESTIMATOR_H

#include <stdint.h>

#include "proto/messages.h"

#define ESTIMATOR_VALUE_SIZE 4u
#define ESTIMATOR_ANY_LENGTH 0u /* n_inputs of an estimator that takes any body */

typedef struct {
    uint8_t id;            /* stable number on the wire */
    const char *name;      /* short, lower case; the host's registry key */
    uint8_t modes;         /* bitmask of 1 << MODE_* */
    uint8_t n_inputs;      /* values per SAMPLE, or ESTIMATOR_ANY_LENGTH */
    uint8_t n_outputs;     /* values per RESULT (ignored for ESTIMATOR_ANY_LENGTH) */
    uint8_t n_params;      /* values in CONFIG */
    /* Checks and stores the parameters and resets the state. Returns 0, or
     * 1 + the index of the first parameter out of range. */
    uint8_t (*configure)(void *state, uint8_t mode, const uint8_t *params);
    /* Back to the state right after configure. */
    void (*reset)(void *state);
    /* One sample: reads in[0..in_len), writes out, returns STATUS_* bits.
     * *out_len is set to the bytes written. */
    uint8_t (*step)(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                    uint8_t *out_len);
} estimator_t;

/* Registry: estimator_at(i) for i < estimator_count(), or NULL. */
uint8_t estimator_count(void);
const estimator_t *estimator_at(uint8_t index);
const estimator_t *estimator_by_id(uint8_t id);

/* The one state area all estimators share (only one is configured at a time). */
void *estimator_state(void);

#endif
