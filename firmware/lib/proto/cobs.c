#include "proto/cobs.h"

uint16_t cobs_encode(const uint8_t *src, uint16_t len, uint8_t *dst)
{
    uint16_t code_at = 0; /* where the current block's length code goes */
    uint16_t out = 1;
    uint8_t code = 1;
    for (uint16_t i = 0; i < len; i++) {
        if (src[i] != 0) {
            dst[out++] = src[i];
            code++;
        }
        /* A full block ends without standing for a zero; open the next only if data follows. */
        if (src[i] == 0 || (code == 0xFF && i + 1u < len)) {
            dst[code_at] = code;
            code_at = out++;
            code = 1;
        }
    }
    dst[code_at] = code;
    return out;
}

int16_t cobs_decode(const uint8_t *src, uint16_t len, uint8_t *dst)
{
    uint16_t in = 0;
    uint16_t out = 0;
    while (in < len) {
        uint8_t code = src[in++];
        if (code == 0 || (uint16_t)(in + code - 1u) > len) {
            return -1;
        }
        for (uint8_t i = 1; i < code; i++) {
            uint8_t byte = src[in++];
            if (byte == 0) {
                return -1;
            }
            dst[out++] = byte;
        }
        /* A block shorter than 254 data bytes stands for a zero, except at the end. */
        if (code != 0xFF && in < len) {
            dst[out++] = 0;
        }
    }
    return (int16_t)out;
}
