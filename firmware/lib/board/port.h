/* What the message core needs from the platform it runs on. firmware/src
 * implements it for the ATmega2560, firmware/native for the host build. */
#ifndef VEHIL_BOARD_PORT_H
#define VEHIL_BOARD_PORT_H

#include <stdint.h>

/* Free-running counter of CPU cycles (wraps at 2^32) and its rate in Hz.
 * uint32_t port_cycles(void) comes from the platform's port_inline.h (firmware/src,
 * firmware/native), so the AVR's can be inline: every frame the core handles reads it. */
uint32_t port_cycles_per_second(void);

/* PORT_CODE_MARK(name), from port_inline.h: on the AVR, a symbol `name` at that point
 * of the code and no instruction, which vehil profile finds in the ELF (a window opens
 * or closes there); nothing on the host. Each may appear once in an image. */

/* Frames are encoded straight into the TX buffer. port_tx_open() appends a
 * placeholder (a COBS code byte, known only when its block ends) and holds it and
 * everything after it back; port_tx_put() appends a byte; port_tx_close() writes the
 * placeholder and lets everything appended so far go out. One placeholder at a time;
 * appending waits while the buffer is full. */
void port_tx_open(void);
void port_tx_close(uint8_t code);
/* port_tx_put(byte) comes from the platform's port_tx.h (firmware/src, firmware/native),
 * so the AVR's can be inline: every byte of every reply goes through it. */
/* Returns once every queued byte has left the UART. */
void port_flush(void);

/* The first n bytes handed to dispatch_bytes() are done with: the RX buffer may reuse them. */
void port_rx_release(uint8_t n);
/* Bytes the RX buffer holds; the host keeps no more than this in flight. */
uint16_t port_rx_buffer(void);
/* Bytes dropped because the RX buffer was full, since boot (saturating):
 * uint16_t port_rx_overruns(void), from port_inline.h, read after every frame. */
/* A mark of the UART interrupts' work so far, and the cycles they have taken since a
 * mark: a step's cycles are its own, whatever bytes arrive or leave while it runs. */
uint16_t port_irq_mark(void);
uint16_t port_irq_cycles(uint16_t mark);

uint32_t port_baud(void);
/* 0 if the UART can run at baud, else the |error| in 0.01 % (0xFFFF: not at all). */
uint16_t port_baud_error(uint32_t baud);
void port_set_baud(uint32_t baud);

uint16_t port_free_ram(void);
uint16_t port_stack_size(void);
/* Stack bytes never written since boot (painted-stack high-water mark). */
uint16_t port_stack_unused(void);

uint16_t port_boot_count(void);
uint8_t port_reset_cause(void); /* RESET_CAUSE_* */
/* Restarts the board; on the AVR through the watchdog, so it does not return. */
void port_reboot(void);
/* Hangs with interrupts off, not feeding the watchdog: it must reset the board. */
void port_hang(void);

#endif
