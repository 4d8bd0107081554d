/* The port.h functions the message core calls for every frame, inline for the
 * ATmega2560 (see board/port.h). */
#ifndef VEHIL_PORT_INLINE_H
#define VEHIL_PORT_INLINE_H

#include <stdint.h>
#include <util/atomic.h>

#include "cycles.h"
#include "uart.h"

/* A local symbol `name` at this point of the code, and no instruction (port.h). */
#define PORT_CODE_MARK(name) __asm__ __volatile__(#name ":" ::)

static inline uint32_t port_cycles(void) { return cycles_now(); }

static inline uint16_t port_rx_overruns(void)
{
    uint16_t n;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { n = uart_rx_lost; }
    return n;
}

#endif
