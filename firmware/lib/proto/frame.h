/* Frames: COBS(type | seq | body | crc16-le) followed by a 0x00 delimiter. */
#ifndef VEHIL_PROTO_FRAME_H
#define VEHIL_PROTO_FRAME_H

#include <stdint.h>

#include "proto/cobs.h"
#include "proto/messages.h"

#define FRAME_HEADER_SIZE 2u /* type, seq */
#define FRAME_CRC_SIZE 2u
#define FRAME_RAW_MAX (FRAME_HEADER_SIZE + VEHIL_MAX_BODY + FRAME_CRC_SIZE)
/* Largest frame on the wire, delimiter included. */
#define FRAME_WIRE_MAX (COBS_MAX_ENCODED(FRAME_RAW_MAX) + 1u)

typedef enum {
    FRAME_OK = 0,
    FRAME_BAD_COBS,
    FRAME_TOO_SHORT,
    FRAME_BAD_CRC,
} frame_status_t;

typedef struct {
    uint8_t type;
    uint8_t seq;
    const uint8_t *body;
    uint16_t body_len;
} frame_t;

/* Writes the whole wire frame (delimiter included) into out, which must hold
 * FRAME_WIRE_MAX bytes; body_len must not exceed VEHIL_MAX_BODY. Returns the length. */
uint16_t frame_encode(uint8_t type, uint8_t seq, const uint8_t *body, uint16_t body_len,
                      uint8_t *out);

/* Decodes the bytes between two delimiters in place; on FRAME_OK, frame->body
 * points into buf. */
frame_status_t frame_decode(uint8_t *buf, uint16_t len, frame_t *frame);

#endif
