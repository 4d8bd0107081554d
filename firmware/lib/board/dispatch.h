/* The board's message core: assembles frames from received bytes, answers
 * each request with exactly one reply, and keeps the link statistics. Pure
 * C99 over port.h, so the host build runs the very same code. */
#ifndef VEHIL_BOARD_DISPATCH_H
#define VEHIL_BOARD_DISPATCH_H

#include <stdint.h>

#define VEHIL_FW_MAJOR 0u
#define VEHIL_FW_MINOR 1u
#define VEHIL_FW_PATCH 0u

/* Resets the core and announces the board with an unsolicited INFO (seq 0). */
void dispatch_init(void);

/* Feeds received bytes (read where they lie, in the platform's RX buffer); each
 * complete frame is handled before this returns, once port_rx_release() has given
 * back the bytes up to its delimiter. */
void dispatch_bytes(const uint8_t *data, uint8_t len);

#endif
