/* Frames, protocol v3: COBS(type u8 | seq u16 | len u8 | body | crc u32) 0x00, all
 * little-endian. The CRC-32C covers one byte that is not sent, the type of the
 * request the frame answers (0 for a request, or for a frame the board sends on its
 * own), then type .. body: a reply passes only as the answer to its own request.
 * `len` is the body's length, checked against the bytes received.
 *
 * Both directions work a byte at a time, with no whole-frame buffers: the receiver
 * decodes COBS and runs the CRC as bytes arrive; the sender encodes COBS and the CRC
 * straight into the platform's transmit buffer (port.h). */
#ifndef VEHIL_PROTO_FRAME_H
#define VEHIL_PROTO_FRAME_H

#include <stdint.h>

#include "proto/messages.h"

#define FRAME_HEADER_SIZE 4u /* type, seq, len */
#define FRAME_CRC_SIZE 4u
#define FRAME_RAW_MAX (FRAME_HEADER_SIZE + VEHIL_MAX_BODY + FRAME_CRC_SIZE)
/* Largest frame on the wire: a COBS code byte per 254 bytes, then the delimiter. */
#define FRAME_WIRE_MAX (FRAME_RAW_MAX + FRAME_RAW_MAX / 254u + 2u)

typedef enum {
    FRAME_MORE = 0, /* not a delimiter: the frame goes on */
    FRAME_OK,
    FRAME_IDLE,     /* a delimiter with no frame before it */
    FRAME_BAD_COBS, /* a code byte pointing past the delimiter */
    FRAME_BAD_CRC,  /* CRC, length field or a frame too short to hold them */
    FRAME_OVERSIZE, /* more than FRAME_RAW_MAX decoded bytes */
} frame_status_t;

/* A frame being received. On FRAME_OK, raw holds type, seq, len, body and CRC. */
typedef struct {
    uint8_t lead[FRAME_HEADER_SIZE]; /* a reply's header, just before raw (frame_tx_echo) */
    uint8_t raw[FRAME_RAW_MAX];
    uint8_t n;      /* bytes decoded */
    uint8_t left;   /* data bytes left in the COBS block; 0: the next byte is a code */
    uint8_t zero;   /* the block ends in an implied zero, emitted if the frame goes on */
    uint8_t status; /* FRAME_MORE while the frame is good so far */
    uint32_t crc;
    uint32_t crc_start; /* the CRC over the answered type: where each frame's starts */
} frame_rx_t;

/* Starts a frame that answers a request of type `answers` (0: a request). */
void frame_rx_reset(frame_rx_t *rx, uint8_t answers);
/* Feeds bytes up to and including the first delimiter among them; returns how many it
 * took. *st is the verdict of the frame that delimiter ended (the next frame then
 * starts, answering the same type), or FRAME_MORE if there was none. The frame stays
 * readable in raw until more bytes are fed. On the AVR data lies in the UART's RX ring
 * and the call goes on with the bytes that come in after these while it runs, so it
 * may take more than len (firmware/src/frame_avr.S). */
uint8_t frame_rx_bytes(frame_rx_t *rx, const uint8_t *data, uint8_t len, frame_status_t *st);

static inline uint8_t frame_type(const frame_rx_t *rx) { return rx->raw[0]; }
static inline uint16_t frame_seq(const frame_rx_t *rx)
{
    return (uint16_t)(rx->raw[1] | ((uint16_t)rx->raw[2] << 8));
}
static inline uint8_t frame_body_len(const frame_rx_t *rx) { return rx->raw[3]; }
static inline const uint8_t *frame_body(const frame_rx_t *rx) { return rx->raw + FRAME_HEADER_SIZE; }

/* A frame being sent: begin, the body's bytes (exactly len of them), end. */
typedef struct {
    uint32_t crc;
    uint8_t code; /* the COBS block's code so far */
} frame_tx_t;

void frame_tx_begin(frame_tx_t *tx, uint8_t answers, uint8_t type, uint16_t seq, uint8_t len);
void frame_tx_bytes(frame_tx_t *tx, const uint8_t *data, uint8_t n);
void frame_tx_end(frame_tx_t *tx);

/* A reply that echoes the received frame's body after a head of FRAME_HEADER_SIZE bytes
 * (a PONG), encoded in one run from the frame's own buffer: the head is written at
 * frame_echo_head(), over the request's header (read it first), the reply's header
 * goes just before it, and header, head and body go through the encoder at once. */
static inline uint8_t *frame_echo_head(frame_rx_t *rx) { return rx->raw; }
void frame_tx_echo(frame_rx_t *rx, uint8_t answers, uint8_t type, uint16_t seq, uint8_t body_len);

#endif
