#include "proto/frame.h"

#include <string.h>

#include "proto/crc16.h"
#include "proto/wire.h"

uint16_t frame_encode(uint8_t type, uint8_t seq, const uint8_t *body, uint16_t body_len,
                      uint8_t *out)
{
    uint8_t raw[FRAME_RAW_MAX];
    raw[0] = type;
    raw[1] = seq;
    memcpy(raw + FRAME_HEADER_SIZE, body, body_len);
    uint16_t n = (uint16_t)(FRAME_HEADER_SIZE + body_len);
    put_u16(raw + n, crc16(raw, n));
    n = cobs_encode(raw, (uint16_t)(n + FRAME_CRC_SIZE), out);
    out[n++] = 0;
    return n;
}

frame_status_t frame_decode(uint8_t *buf, uint16_t len, frame_t *frame)
{
    int16_t n = cobs_decode(buf, len, buf);
    if (n < 0) {
        return FRAME_BAD_COBS;
    }
    if (n < (int16_t)(FRAME_HEADER_SIZE + FRAME_CRC_SIZE)) {
        return FRAME_TOO_SHORT;
    }
    uint16_t covered = (uint16_t)n - FRAME_CRC_SIZE;
    if (crc16(buf, covered) != get_u16(buf + covered)) {
        return FRAME_BAD_CRC;
    }
    frame->type = buf[0];
    frame->seq = buf[1];
    frame->body = buf + FRAME_HEADER_SIZE;
    frame->body_len = (uint16_t)(covered - FRAME_HEADER_SIZE);
    return FRAME_OK;
}
