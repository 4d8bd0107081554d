/* libFuzzer harness: arbitrary bytes into the firmware's message core (the native
 * board: frame assembly, COBS, CRC, dispatch, every estimator), built with ASan and
 * UBSan. Beyond "no crash", it checks the board's side of the contract: everything
 * it sends back is a well-formed frame. */
#include <stdint.h>
#include <stdlib.h>

#include "proto/frame.h"

void vehil_native_power_on(void);
void vehil_native_write(const uint8_t *data, uint32_t len);
uint32_t vehil_native_read(uint8_t *dst, uint32_t max);

static uint8_t out[65536];

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    vehil_native_power_on();
    vehil_native_write(data, (uint32_t)size);
    uint32_t n = vehil_native_read(out, sizeof out);
    uint32_t start = 0;
    for (uint32_t i = 0; i < n; i++) {
        if (out[i] != 0) {
            continue;
        }
        frame_t f;
        if (i > start && frame_decode(out + start, (uint16_t)(i - start), &f) != FRAME_OK) {
            abort(); /* the board sent a frame that does not decode */
        }
        start = i + 1;
    }
    if (start != n) {
        abort(); /* a reply without its closing delimiter */
    }
    return 0;
}
