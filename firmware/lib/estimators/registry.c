/* The estimators built into this image. Adding one: include its header, add
 * its state to the union and its descriptor to the table.
 * VEHIL_EV_FILTERS adds seed 001's 7-state EKF and UKF: the native build and the AVR
 * env `offline-ev` have them; the default AVR image leaves them out, as neither keeps
 * a 10 ms step (README, "What runs on the board"). Its reduced EKF does, with linear
 * tires and a fixed R. */
#include <stddef.h>

#include "estimators/acc_kf.h"
#include "estimators/eso.h"
#include "estimators/estimator.h"
#ifdef VEHIL_EV_FILTERS
#include "estimators/ev_ekf.h"
#include "estimators/ev_ukf.h"
#endif
#include "estimators/ev_ekf3.h"
#include "estimators/kfui.h"
#include "estimators/manf.h"
#include "estimators/passthrough.h"
#include "estimators/rls.h"
#include "estimators/stlqf.h"
#include "estimators/uiiekf.h"

static union {
    passthrough_state_t passthrough;
    acc_kf_state_t acc_kf;
    manf_state_t manf;
    uiiekf_state_t uiiekf;
    eso_state_t eso;
    kfui_state_t kfui;
    stlqf_state_t stlqf;
    rls_state_t rls;
    ev_ekf3_state_t ev_ekf3;
#ifdef VEHIL_EV_FILTERS
    ev_ekf_state_t ev_ekf;
    ev_ukf_state_t ev_ukf;
#endif
} state;

static const ROM estimator_t *const ROM registry[] = {
    &passthrough_estimator,
    &acc_kf_estimator,
    &manf_estimator,
    &uiiekf_estimator,
    &eso_estimator,
    &kfui_estimator,
    &stlqf_estimator,
    &rls_estimator,
    &ev_ekf3_estimator,
#ifdef VEHIL_EV_FILTERS
    &ev_ekf_estimator,
    &ev_ukf_estimator,
#endif
};

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
