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

/* Feeds one received byte; a complete frame is handled before this returns. */
void dispatch_byte(uint8_t byte);

#endif
