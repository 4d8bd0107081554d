/* Start-up of the ATmega2560 side of port.h. */
#ifndef VEHIL_PORT_AVR_H
#define VEHIL_PORT_AVR_H

/* Reads the reset cause, counts the boot, starts Timer1 and UART0. */
void port_avr_init(void);

#endif
