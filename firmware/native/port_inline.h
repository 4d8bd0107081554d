/* The port.h functions the AVR's build has inline (see board/port.h), in port_native.c. */
#ifndef VEHIL_PORT_INLINE_H
#define VEHIL_PORT_INLINE_H

#include <stdint.h>

#define PORT_CODE_MARK(name) /* the host's build is not profiled by address */

uint32_t port_cycles(void);
uint16_t port_rx_overruns(void);

#endif
