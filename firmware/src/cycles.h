/* Timer1 at clk/1 with a software overflow count: a 32-bit cycle counter. */
#ifndef VEHIL_CYCLES_H
#define VEHIL_CYCLES_H

#include <stdint.h>

void cycles_init(void);
uint32_t cycles_now(void);

#endif
