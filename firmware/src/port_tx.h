/* port_tx_put for the ATmega2560: the TX ring's append, inline (see board/port.h). */
#ifndef VEHIL_PORT_TX_H
#define VEHIL_PORT_TX_H

#include <stdint.h>

#include "uart.h"

static inline void port_tx_put(uint8_t byte) { uart_tx_put(byte); }

#endif
