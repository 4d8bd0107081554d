/* The registry of the estimators built into this image. Which ones is the build's
 * choice (platformio.ini's custom_estimators; the native build and the fuzzer take them
 * all): it writes registry_gen.h with their headers, their states for the union and
 * their descriptors (host/vehil/build/registry.py). Adding an estimator edits no file
 * here. The default AVR image leaves out seed 001's 7-state EKF and UKF, as neither
 * keeps a 10 ms step (README, "What runs on the board"); env `offline-ev` has them. */
#include <stddef.h>

#include "estimators/estimator.h"
#include "registry_gen.h"

static union {
    VEHIL_REGISTRY_STATES
} state;

static const ROM estimator_t *const ROM registry[] = {VEHIL_REGISTRY_ENTRIES};

uint8_t estimator_count(void) { return (uint8_t)(sizeof registry / sizeof registry[0]); }

static const estimator_t *entry(uint8_t index)
{
    return (const estimator_t *)rom_ptr((const void *const *)&registry[index]);
}

uint8_t estimator_index(uint8_t id)
{
    uint8_t i = 0;
    while (i < estimator_count() && rom_u8(&entry(i)->id) != id) {
        i++;
    }
    return i;
}

uint8_t estimator_load(uint8_t index, estimator_t *out)
{
    if (index >= estimator_count()) {
        return 0;
    }
    rom_copy(out, entry(index), offsetof(estimator_t, name));
    return 1;
}

uint8_t estimator_name(uint8_t index, uint8_t *buf)
{
    const char *name = entry(index)->name;
    uint8_t n = 0;
    while (n < ESTIMATOR_NAME_SIZE - 1u && (buf[n] = rom_u8((const uint8_t *)&name[n])) != 0u) {
        n++;
    }
    return n;
}

void *estimator_state(void) { return &state; }
