#include "estimators/passthrough.h"

#include <string.h>

static uint8_t passthrough_configure(void *state, uint8_t mode, const uint8_t *params)
{
    (void)state;
    (void)mode;
    (void)params;
    return 0;
}

static void passthrough_reset(void *state) { (void)state; }

static uint8_t passthrough_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                                uint8_t *out_len)
{
    (void)state;
    memcpy(out, in, in_len);
    *out_len = in_len;
    return 0;
}

const ROM estimator_t passthrough_estimator = {
    .id = PASSTHROUGH_ID,
    .name = "passthrough",
    .modes = (1u << MODE_F32) | (1u << MODE_FIXED),
    .n_inputs = ESTIMATOR_ANY_LENGTH,
    .n_outputs = ESTIMATOR_ANY_LENGTH,
    .n_params = 0,
    .configure = passthrough_configure,
    .reset = passthrough_reset,
    .step = passthrough_step,
};
