/* The port.h functions the AVR's build has inline (see board/port.h), in port_native.c. */
#ifndef VEHIL_PORT_INLINE_H
#define VEHIL_PORT_INLINE_H

#include <stdint.h>

uint32_t port_cycles(void);
uint16_t port_rx_overruns(void);

#endif
