#include "proto/frame.h"

#include <stddef.h>

#include "board/port.h"
#include "port_tx.h"
#include "proto/crc32c.h"

/* The next frame, answering the same type: its CRC starts where every such frame's does. */
static void rx_restart(frame_rx_t *rx)
{
    rx->n = 0;
    rx->left = 0;
    rx->zero = 0;
    rx->status = FRAME_MORE;
    rx->crc = rx->crc_start;
}

void frame_rx_reset(frame_rx_t *rx, uint8_t answers)
{
    rx->crc_start = crc32c_update(CRC32C_INIT, answers);
    rx_restart(rx);
}

#if defined(__AVR__)
/* frame_rx_bytes() is firmware/src/frame_avr.S's, the C below in assembly, with its
 * offsets and verdicts' values spelled out there. */
typedef char frame_rx_avr_layout[(offsetof(frame_rx_t, n) == FRAME_HEADER_SIZE + 136u &&
                                  FRAME_RAW_MAX == 136u && offsetof(frame_rx_t, left) == 141u &&
                                  offsetof(frame_rx_t, zero) == 142u &&
                                  offsetof(frame_rx_t, status) == 143u &&
                                  offsetof(frame_rx_t, crc) == 144u &&
                                  offsetof(frame_rx_t, crc_start) == 148u && FRAME_OK == 1 &&
                                  FRAME_IDLE == 2 && FRAME_BAD_COBS == 3 && FRAME_BAD_CRC == 4 &&
                                  FRAME_OVERSIZE == 5)
                                     ? 1
                                     : -1];
#else
static void rx_emit(frame_rx_t *rx, uint8_t byte)
{
    if (rx->n == FRAME_RAW_MAX) {
        rx->status = FRAME_OVERSIZE; /* the rest is dropped up to the delimiter */
        return;
    }
    rx->raw[rx->n++] = byte;
    rx->crc = crc32c_update(rx->crc, byte);
}

static frame_status_t rx_end(frame_rx_t *rx, uint8_t started)
{
    frame_status_t st = (frame_status_t)rx->status;
    if (st == FRAME_MORE) {
        if (!started) {
            st = FRAME_IDLE;
        } else if (rx->left != 0) {
            st = FRAME_BAD_COBS;
        } else if (rx->n < FRAME_HEADER_SIZE + FRAME_CRC_SIZE || rx->crc != CRC32C_RESIDUE ||
                   rx->raw[3] != (uint8_t)(rx->n - FRAME_HEADER_SIZE - FRAME_CRC_SIZE)) {
            st = FRAME_BAD_CRC;
        } else {
            st = FRAME_OK;
        }
    }
    return st;
}

/* Code bytes, the delimiter, and bytes after an error. */
static frame_status_t rx_other(frame_rx_t *rx, uint8_t byte)
{
    if (byte == 0) {
        uint8_t started = rx->n != 0 || rx->left != 0 || rx->zero || rx->status != FRAME_MORE;
        frame_status_t st = rx_end(rx, started);
        rx_restart(rx); /* raw is kept: the frame is read before the next byte */
        return st;
    }
    if (rx->status == FRAME_MORE) {
        if (rx->zero) {
            rx_emit(rx, 0); /* the previous block's zero: the frame went on */
        }
        rx->left = (uint8_t)(byte - 1u);
        rx->zero = byte != 0xFFu;
    }
    return FRAME_MORE;
}

/* Copies up to k bytes of a COBS block's data, up to a zero, running the CRC over
 * them; returns how many it took. */
static uint8_t frame_rx_run(uint32_t *crc, uint8_t *dst, const uint8_t *src, uint8_t k)
{
    uint32_t c = *crc;
    uint8_t took = 0;
    while (took != k && src[took] != 0) {
        c = crc32c_update(c, src[took]);
        dst[took] = src[took];
        took++;
    }
    *crc = c;
    return took;
}

uint8_t frame_rx_bytes(frame_rx_t *rx, const uint8_t *data, uint8_t len, frame_status_t *st)
{
    const uint8_t *p = data;
    const uint8_t *end = data + len;
    *st = FRAME_MORE;
    while (p != end) {
        if (rx->left != 0 && *p != 0 && rx->status == FRAME_MORE) {
            /* Most bytes: a COBS block's data, taken in one run with the CRC in registers. */
            uint8_t room = (uint8_t)(FRAME_RAW_MAX - rx->n);
            if (room == 0) {
                rx->status = FRAME_OVERSIZE; /* the rest is dropped up to the delimiter */
                continue;
            }
            uint8_t k = rx->left < room ? rx->left : room;
            if ((uint8_t)(end - p) < k) {
                k = (uint8_t)(end - p);
            }
            uint8_t took = frame_rx_run(&rx->crc, rx->raw + rx->n, p, k);
            p += took;
            rx->n = (uint8_t)(rx->n + took);
            rx->left = (uint8_t)(rx->left - took);
            continue;
        }
        frame_status_t s = rx_other(rx, *p++);
        if (s != FRAME_MORE) {
            *st = s;
            break;
        }
    }
    return (uint8_t)(p - data);
}

#endif

/* No COBS block reaches the 254 data bytes that would end it without a zero. */
typedef char frame_blocks_end_at_zeros[FRAME_RAW_MAX < 254u ? 1 : -1];

/* One byte into the COBS encoder; returns the block's code so far. A zero ends the
 * block (its code stands for the zero) and opens the next. */
static inline uint8_t tx_cobs(uint8_t code, uint8_t byte)
{
    if (byte == 0) {
        port_tx_close(code);
        port_tx_open();
        return 1;
    }
    port_tx_put(byte);
    return (uint8_t)(code + 1u);
}

#if defined(__AVR__)
/* firmware/src/frame_avr.S: the loop below in assembly, straight into the UART's TX ring. */
uint8_t frame_tx_run(uint32_t *crc, uint8_t code, const uint8_t *data, uint8_t n);
#else
/* n bytes into the TX buffer, COBS-encoded, the CRC run over them; returns the COBS
 * code of the block so far. A zero byte ends the block. */
static uint8_t frame_tx_run(uint32_t *crc, uint8_t code, const uint8_t *data, uint8_t n)
{
    uint32_t c = *crc;
    while (n-- > 0u) {
        uint8_t byte = *data++;
        c = crc32c_update(c, byte);
        code = tx_cobs(code, byte);
    }
    *crc = c;
    return code;
}
#endif

static void header_pack(uint8_t *header, uint8_t type, uint16_t seq, uint8_t len)
{
    header[0] = type;
    header[1] = (uint8_t)seq;
    header[2] = (uint8_t)(seq >> 8);
    header[3] = len;
}

static void tx_open(frame_tx_t *tx, uint8_t answers)
{
    tx->crc = crc32c_update(CRC32C_INIT, answers);
    tx->code = 1;
    port_tx_open();
}

void frame_tx_begin(frame_tx_t *tx, uint8_t answers, uint8_t type, uint16_t seq, uint8_t len)
{
    uint8_t header[FRAME_HEADER_SIZE];
    header_pack(header, type, seq, len);
    tx_open(tx, answers);
    frame_tx_bytes(tx, header, sizeof header);
}

#if defined(__AVR__)
/* firmware/src/frame_avr.S: tx_open(), frame_tx_bytes() and frame_tx_end() below, in
 * one call of assembly. */
void frame_tx_frame(uint8_t answers, const uint8_t *data, uint8_t n);
#else
/* A whole frame whose header and body lie in one buffer. */
static void frame_tx_frame(uint8_t answers, const uint8_t *data, uint8_t n)
{
    frame_tx_t tx;
    tx_open(&tx, answers);
    frame_tx_bytes(&tx, data, n);
    frame_tx_end(&tx);
}
#endif

/* lead, then raw: one buffer. */
typedef char frame_lead_before_raw
    [offsetof(frame_rx_t, raw) == offsetof(frame_rx_t, lead) + FRAME_HEADER_SIZE ? 1 : -1];

void frame_tx_echo(frame_rx_t *rx, uint8_t answers, uint8_t type, uint16_t seq, uint8_t body_len)
{
    header_pack(rx->lead, type, seq, (uint8_t)(FRAME_HEADER_SIZE + body_len));
    frame_tx_frame(answers, rx->lead, (uint8_t)(2u * FRAME_HEADER_SIZE + body_len));
}

void frame_tx_bytes(frame_tx_t *tx, const uint8_t *data, uint8_t n)
{
    tx->code = frame_tx_run(&tx->crc, tx->code, data, n);
}

#if defined(__AVR__)
/* firmware/src/frame_avr.S: the loop below in assembly. */
uint8_t frame_tx_crc(uint32_t crc, uint8_t code);
#else
/* The CRC's bytes, low first, into the TX buffer, COBS-encoded but not run through the
 * CRC; returns the block's code. */
static uint8_t frame_tx_crc(uint32_t crc, uint8_t code)
{
    for (uint8_t i = 0; i < FRAME_CRC_SIZE; i++) {
        code = tx_cobs(code, (uint8_t)crc);
        crc >>= 8;
    }
    return code;
}
#endif

void frame_tx_end(frame_tx_t *tx)
{
    uint8_t code = frame_tx_crc(tx->crc ^ CRC32C_XOROUT, tx->code);
    port_tx_put(0); /* the delimiter, released with the last block */
    port_tx_close(code);
}

