/* vehil firmware: boots, announces itself, then feeds every received byte to
 * the message core, where they lie in the RX ring. It never sleeps: QEMU's mega2560 does not wake from
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
        uint8_t n;
        const uint8_t *bytes = uart_rx_wait(&n);
        dispatch_bytes(bytes, n);
    }
}
