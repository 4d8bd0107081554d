/* Reading and range-checking CONFIG parameters in either numeric mode, so each
 * estimator states its table once instead of parsing bytes. */
#ifndef VEHIL_ESTIMATORS_PARAMS_H
#define VEHIL_ESTIMATORS_PARAMS_H

#include <stdint.h>

#include "rom/rom.h"

#ifdef __cplusplus
extern "C" { /* C linkage for C++ wrappers of vendored libraries */
#endif

/* One parameter's accepted range. Tables of them live in flash, declared
 * `static const ROM param_range_t name[N] = {{lo, hi, q}, ...};`, and are read only
 * through param_range_q and params_check (the fields' names say so: a plain read of
 * a flash table gives a wrong value on the AVR). */
typedef struct {
    float lo_rom, hi_rom; /* accepted range, inclusive */
    uint8_t q_rom;        /* fractional bits of the value in FIXED mode */
} param_range_t;

/* The fractional bits of ranges[i]. */
static inline uint8_t param_range_q(const param_range_t *ranges, uint8_t i)
{
    return rom_u8(&ranges[i].q_rom);
}

/* Parameter i as a float, whatever the mode (for checks, not for fixed-point maths). */
float param_value(const uint8_t *params, uint8_t i, uint8_t mode, uint8_t q);

/* Parameter i as it came: an int32 Q value in FIXED mode. */
int32_t param_q(const uint8_t *params, uint8_t i);

/* x^k for 0 <= x < 2, k > 0, from IEEE operations alone (a rate per time made a rate per
 * sample at CONFIG, the same bits on the chip and the host); relative error ~1e-6, results
 * past 2 give 2. */
float param_pow(float x, float k);

/* 0 if every parameter is finite and in range, else 1 + the first bad index. */
uint8_t params_check(const uint8_t *params, uint8_t mode, const param_range_t *ranges, uint8_t n);

#ifdef __cplusplus
}
#endif

#endif
