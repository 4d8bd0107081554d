/* vehil firmware: boots, announces itself, then feeds every received byte to
 * the message core. It never sleeps: QEMU's mega2560 does not wake from
 * sleep_cpu(), and a busy loop costs nothing on a dedicated board. */
#include <avr/interrupt.h>
#include <avr/wdt.h>

#include "board/dispatch.h"
#include "port_avr.h"
#include "uart.h"

int main(void)
{
    port_avr_init();
    wdt_enable(WDTO_1S); /* a hung step or loop reboots the board; INFO says so */
    sei();
    dispatch_init();
    for (;;) {
        dispatch_byte(uart_wait_byte());
    }
}
