/* port.h for the host build: the message core runs in-process behind a byte
 * pipe, so the host's `native://` link speaks the same protocol as a board.
 * Cycles are nanoseconds of the host's monotonic clock. */
#define _POSIX_C_SOURCE 199309L
#include <stdint.h>
#include <string.h>
#include <time.h>

#include "board/dispatch.h"
#include "board/port.h"
#include "port_inline.h"
#include "port_tx.h"
#include "proto/messages.h"

#define NATIVE_OUT_SIZE 65536u
#define NATIVE_RX_BUFFER 4096u /* no real buffer: the window the host may use */

static uint8_t out_buf[NATIVE_OUT_SIZE];
static uint32_t out_len;      /* bytes the host may read */
static uint32_t out_write;    /* bytes appended, released or not */
static uint32_t out_held;     /* the placeholder */
static uint32_t out_dropped;
static uint32_t baud = 1000000u;
static uint16_t boot_count;
static uint8_t reset_cause;

uint32_t port_cycles(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint32_t)((uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec);
}

uint32_t port_cycles_per_second(void) { return 1000000000u; }

void port_tx_put(uint8_t byte)
{
    if (out_write == NATIVE_OUT_SIZE) {
        out_dropped++; /* the host stopped reading; it sees the loss as missing replies */
        return;
    }
    out_buf[out_write++] = byte;
}

void port_tx_open(void)
{
    out_held = out_write;
    port_tx_put(0);
}

void port_tx_close(uint8_t code)
{
    if (out_held < out_write) {
        out_buf[out_held] = code;
    }
    out_len = out_write;
}

void port_rx_release(uint8_t n) { (void)n; } /* the bytes are the caller's */
void port_flush(void) {}
uint16_t port_rx_buffer(void) { return NATIVE_RX_BUFFER; }
uint16_t port_rx_overruns(void) { return 0; }
uint16_t port_irq_mark(void) { return 0; } /* no interrupts: the bytes are the caller's */
uint16_t port_irq_cycles(uint16_t mark) { return (uint16_t)(mark - mark); }
uint32_t port_baud(void) { return baud; }
uint16_t port_baud_error(uint32_t b) { return b == 0 ? 0xFFFFu : 0; }
void port_set_baud(uint32_t b) { baud = b; }
uint16_t port_free_ram(void) { return 0; }
uint16_t port_stack_size(void) { return 0; }
uint16_t port_stack_unused(void) { return 0; }
uint16_t port_boot_count(void) { return boot_count; }
uint8_t port_reset_cause(void) { return reset_cause; }

static void boot(uint8_t cause)
{
    boot_count++;
    reset_cause = cause;
    baud = 1000000u;
    dispatch_init();
}

void port_reboot(void) { boot(RESET_CAUSE_SOFTWARE); }
/* The host build has no watchdog to wait for: it resets as one would. */
void port_hang(void) { boot(RESET_CAUSE_WATCHDOG); }

/* The library's entry points, called by host/vehil/transports/protocol_native.py. */

void vehil_native_power_on(void)
{
    out_len = out_write = 0;
    out_dropped = 0;
    boot_count = 0;
    boot(RESET_CAUSE_POWER_ON);
}

void vehil_native_write(const uint8_t *data, uint32_t len)
{
    while (len > 0u) {
        uint8_t n = len > 255u ? 255u : (uint8_t)len;
        dispatch_bytes(data, n);
        data += n;
        len -= n;
    }
}

uint32_t vehil_native_read(uint8_t *dst, uint32_t max)
{
    uint32_t n = out_len < max ? out_len : max;
    memcpy(dst, out_buf, n);
    memmove(out_buf, out_buf + n, out_write - n);
    out_len -= n;
    out_write -= n;
    return n;
}

uint32_t vehil_native_dropped(void) { return out_dropped; }
