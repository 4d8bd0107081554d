/* port.h for the ATmega2560: UART0, Timer1 cycles, painted stack, watchdog,
 * reset cause and a boot counter that survives everything but power loss. */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/wdt.h>

#include "board/port.h"
#include "cycles.h"
#include "port_avr.h"
#include "proto/messages.h"
#include "uart.h"

#define STACK_PAINT 0xC5u
#define BOOT_MAGIC 0x7E5Au
/* The rate the UART boots at: `vehil build --boot-baud` sets another for USB-serial
 * adapters that cannot run 1 Mbaud (README, "A board through a slower adapter"). */
#ifndef VEHIL_BOOT_BAUD
#define VEHIL_BOOT_BAUD UART_DEFAULT_BAUD
#endif
/* Acceptable |baud error|, in 0.01 %: wide enough for 230400 (-3.5 %). */
#define BAUD_ERROR_LIMIT 400u

extern uint8_t _end; /* first byte after .data, .bss and .noinit: the stack's floor */

/* .noinit: left alone by the C start-up, so these survive a watchdog reset. */
static uint16_t boot_magic __attribute__((section(".noinit")));
static uint16_t boot_count __attribute__((section(".noinit")));
static uint8_t reboot_requested __attribute__((section(".noinit")));
static uint8_t mcusr_at_reset __attribute__((section(".noinit")));

/* Runs before main, before .data/.bss exist: save and clear the reset flags
 * (a watchdog reset leaves the watchdog running), then paint the stack. */
void early_init(void) __attribute__((naked, used, section(".init3")));
void early_init(void)
{
    mcusr_at_reset = MCUSR;
    MCUSR = 0;
    wdt_disable();
    for (uint8_t *p = &_end; p <= (uint8_t *)RAMEND; p++) {
        *p = STACK_PAINT;
    }
}

static uint8_t reset_cause;

void port_avr_init(void)
{
    if (reboot_requested == 1u) {
        reset_cause = RESET_CAUSE_SOFTWARE;
    } else if (mcusr_at_reset & _BV(PORF)) {
        reset_cause = RESET_CAUSE_POWER_ON;
    } else if (mcusr_at_reset & _BV(WDRF)) {
        reset_cause = RESET_CAUSE_WATCHDOG;
    } else if (mcusr_at_reset & _BV(BORF)) {
        reset_cause = RESET_CAUSE_BROWN_OUT;
    } else if (mcusr_at_reset & _BV(EXTRF)) {
        reset_cause = RESET_CAUSE_EXTERNAL;
    } else if (mcusr_at_reset & _BV(JTRF)) {
        reset_cause = RESET_CAUSE_JTAG;
    } else {
        reset_cause = RESET_CAUSE_UNKNOWN;
    }
    reboot_requested = 0;
    if (boot_magic != BOOT_MAGIC || reset_cause == RESET_CAUSE_POWER_ON) {
        boot_magic = BOOT_MAGIC;
        boot_count = 0;
    }
    boot_count++;
    cycles_init();
    uart_init(VEHIL_BOOT_BAUD);
}

uint32_t port_cycles_per_second(void) { return F_CPU; }

void port_rx_release(uint8_t n) { uart_rx_release(n); }
void port_tx_open(void) { uart_tx_open(); }
void port_tx_close(uint8_t code) { uart_tx_close(code); }

void port_flush(void) { uart_flush(); }
uint16_t port_rx_buffer(void) { return UART_RX_SIZE - 1u; }

/* The rings' indices count the bytes the interrupts moved (mod 256: no more than a
 * ring's worth can move during a step, the host keeping no more in flight), and each
 * byte costs its interrupt a fixed count. */
uint16_t port_irq_mark(void) { return (uint16_t)(uart_rx_head | ((uint16_t)uart_tx_tail << 8)); }

uint16_t port_irq_cycles(uint16_t mark)
{
    uint8_t received = (uint8_t)(uart_rx_head - (uint8_t)mark);
    uint8_t sent = (uint8_t)(uart_tx_tail - (uint8_t)(mark >> 8));
    return (uint16_t)(received * UART_RX_ISR_CYCLES + sent * UART_TX_ISR_CYCLES);
}
uint32_t port_baud(void) { return uart_baud(); }

uint16_t port_baud_error(uint32_t baud)
{
    int32_t ubrr = uart_ubrr(baud);
    if (ubrr < 0) {
        return 0xFFFFu;
    }
    uint32_t actual = F_CPU / (8UL * (uint32_t)(ubrr + 1));
    uint32_t diff = actual > baud ? actual - baud : baud - actual;
    uint32_t error = (diff * 10000UL + baud / 2u) / baud;
    return error <= BAUD_ERROR_LIMIT ? 0u : (uint16_t)(error > 0xFFFEu ? 0xFFFEu : error);
}

void port_set_baud(uint32_t baud) { uart_init(baud); }

uint16_t port_free_ram(void) { return (uint16_t)(SP - (uint16_t)&_end); }
uint16_t port_stack_size(void) { return (uint16_t)(RAMEND + 1u - (uint16_t)&_end); }

uint16_t port_stack_unused(void)
{
    const uint8_t *p = &_end;
    while (p <= (const uint8_t *)RAMEND && *p == STACK_PAINT) {
        p++;
    }
    return (uint16_t)(p - &_end);
}

uint16_t port_boot_count(void) { return boot_count; }
uint8_t port_reset_cause(void) { return reset_cause; }

void port_hang(void)
{
    cli();
    for (;;) {
        __asm__ __volatile__("" ::: "memory");
    }
}

void port_reboot(void)
{
    reboot_requested = 1;
    cli();
    wdt_enable(WDTO_15MS);
    /* QEMU has no watchdog: if it has not fired after ~50 ms, restart by hand. */
    for (uint32_t spin = 0; spin < F_CPU / 20u / 6u; spin++) {
        __asm__ __volatile__("" ::: "memory");
    }
    wdt_disable();
    __asm__ __volatile__("jmp 0");
}
