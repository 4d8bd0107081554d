/* The interface every estimator implements, and the registry the dispatcher
 * looks estimators up in. Inputs, outputs and parameters are arrays of 4-byte
 * values in the configured numeric mode's format (float32 or int32 Q). */
#ifndef VEHIL_ESTIMATORS_ESTIMATOR_H
#define VEHIL_ESTIMATORS_ESTIMATOR_H

#include <stdint.h>

#include "proto/messages.h"
#include "rom/rom.h"

#ifdef __cplusplus
extern "C" { /* C linkage for C++ wrappers of vendored libraries */
#endif

#define ESTIMATOR_VALUE_SIZE 4u
#define ESTIMATOR_ANY_LENGTH 0u /* n_inputs of an estimator that takes any body */
#define ESTIMATOR_NAME_SIZE 16u /* the name's bytes, its NUL included */

/* A descriptor lives in flash: `const ROM estimator_t NAME_estimator = {...};`. The
 * registry copies what the dispatcher needs into RAM (estimator_load), the name aside. */
typedef struct {
    uint8_t id;            /* stable number on the wire */
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
    char name[ESTIMATOR_NAME_SIZE]; /* short, lower case; the host's registry key. Last:
                                       estimator_load leaves it in flash */
} estimator_t;

/* An opaque slot in an estimator's state for a vendored library's object, whose type the
 * registry cannot see (a header with no include guard, a C++ class): the wrapper's header
 * puts `VEHIL_SLOT(bytes) name;` in NAME_state_t, and its source, which includes the
 * library, checks the type fits with VEHIL_SLOT_CHECK (docs/extending.md). */
#define VEHIL_SLOT(bytes)      \
    union {                    \
        uint8_t bytes_[bytes]; \
        float align_f_;        \
        uint32_t align_u_;     \
        void *align_p_;        \
    }
#ifdef __cplusplus
#define VEHIL_STATIC_ASSERT(cond, message) static_assert(cond, message)
#else
/* GCC and clang have the keyword in C99 too; glibc turns it into a macro before C11 that
 * fails with a negative bit-field and drops the message: the keyword, then. */
#ifdef _Static_assert
#undef _Static_assert
#endif
#define VEHIL_STATIC_ASSERT(cond, message) _Static_assert(cond, message)
#endif
/* At file scope: `VEHIL_SLOT_CHECK(lib_type, NAME_state_t, member);` fails the build, on
 * the host and on the chip (where sizes differ), when the library's type is larger or
 * more aligned than its slot. */
#define VEHIL_SLOT_CHECK(type, state_type, member)                                        \
    VEHIL_STATIC_ASSERT(sizeof(type) <= sizeof(((state_type *)0)->member) &&              \
                            __alignof__(type) <= __alignof__(((state_type *)0)->member), \
                        #type " does not fit " #state_type "." #member                    \
                        ": raise the size in its VEHIL_SLOT")
#define VEHIL_SLOT_AS(type, slot) ((type *)(void *)(slot).bytes_)

/* The registry: indices 0 .. estimator_count() - 1. */
uint8_t estimator_count(void);
/* Index of the estimator with this wire id, or estimator_count() if none. */
uint8_t estimator_index(uint8_t id);
/* Descriptor `index` into RAM, all but its name; 0 if there is none. */
uint8_t estimator_load(uint8_t index, estimator_t *out);
/* Its name's bytes (no NUL) into buf; returns how many. */
uint8_t estimator_name(uint8_t index, uint8_t *buf);

/* The one state area all estimators share (only one is configured at a time). */
void *estimator_state(void);

#ifdef __cplusplus
}
#endif

#endif
