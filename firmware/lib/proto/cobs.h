/* Consistent Overhead Byte Stuffing: removes every 0x00 from a block so 0x00
 * can delimit frames. Encoded size is at most len + len/254 + 1. */
#ifndef VEHIL_PROTO_COBS_H
#define VEHIL_PROTO_COBS_H

#include <stdint.h>

#define COBS_MAX_ENCODED(len) ((len) + (len) / 254u + 1u)

/* Encodes src[0..len) into dst (no trailing delimiter); returns the encoded length. */
uint16_t cobs_encode(const uint8_t *src, uint16_t len, uint8_t *dst);

/* Decodes src[0..len) (no delimiter) into dst, which may be src itself.
 * Returns the decoded length, or -1 if the block is not valid COBS. */
int16_t cobs_decode(const uint8_t *src, uint16_t len, uint8_t *dst);

#endif
