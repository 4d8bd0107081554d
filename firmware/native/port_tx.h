/* port_tx_put for the host build (see board/port.h), in port_native.c. */
#ifndef VEHIL_PORT_TX_H
#define VEHIL_PORT_TX_H

#include <stdint.h>

void port_tx_put(uint8_t byte);

#endif
