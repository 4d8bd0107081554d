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
static frame_rx_t rx;

/* A reply's CRC covers the type of the request it answers, which the harness does
 * not track: a frame is well formed if it checks as the answer to some type. */
static int well_formed(const uint8_t *frame, uint32_t len)
{
    for (unsigned answers = 0; answers < 256u; answers++) {
        frame_rx_reset(&rx, (uint8_t)answers);
        frame_status_t st = FRAME_MORE;
        uint32_t done = 0;
        while (done < len && st == FRAME_MORE) {
            uint8_t chunk = len - done > 255u ? 255u : (uint8_t)(len - done);
            done += frame_rx_bytes(&rx, frame + done, chunk, &st);
        }
        if (st == FRAME_OK && done == len) {
            return 1;
        }
    }
    return 0;
}

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
        if (!well_formed(out + start, i + 1u - start)) {
            abort(); /* the board sent a frame that does not decode */
        }
        start = i + 1;
    }
    if (start != n) {
        abort(); /* a reply without its closing delimiter */
    }
    return 0;
}
