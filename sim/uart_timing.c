/* UART0 timed as the ATmega2560 times it (--uart chip, the default), where simavr 1.6
 * times it otherwise (--uart simavr):
 *  - a frame is start + data bits + parity (if UPM0 enables it) + stop bits, from
 *    UCSR0B/C as they are; simavr always counts a parity bit (11 bits for 8N1);
 *  - the transmitter is double-buffered: a byte written to UDR0 moves into the shift
 *    register at once if it is idle, else when the frame before it ends, and UDRE0 is
 *    set again as it moves; TXC0 is set when a frame ends with UDR0 empty.  simavr
 *    holds UDRE0 off for a whole frame after each write and sets TXC0 after every byte;
 *  - the receiver takes the client's bytes one frame apart, as bytes sent back to back
 *    arrive on the wire, and holds three (the two-byte buffer and the shift register); a
 *    byte that ends with all three unread is lost and sets DOR0.  simavr queues up to 64
 *    and lets the firmware read two a frame time, so a queue of requests came in at up
 *    to twice the line rate.
 * What it does not model is in sim/README.md ("UART0 timing"). */
#include "bridge.h"

#include <avr_uart.h>
#include <sim_gdb.h>
#include <sim_interrupts.h>
#include <sim_irq.h>
#include <sim_regbit.h>

/* the accessors of simavr's pending interrupt FIFO (sim_interrupts.h declares it) and
 * of UART0's receive FIFO (avr_uart.h) */
DEFINE_FIFO(avr_int_vector_p, avr_int_pending);
DEFINE_FIFO(uint16_t, uart_fifo);

#define UPM01 5		/* UCSR0C: parity on (UPM00 says even or odd) */

static avr_uart_t *u;
static int shifting;		/* the shift register holds a frame */
static int udr_full;		/* a byte waits in UDR0 for the shift register */
static uint8_t udr;
int g_rx_busy;			/* a client byte is on its way in: its frame ends on a timer */
#define RX_HELD 3		/* unread bytes the receiver holds: its buffer's two, the shift register's */
static void (*core_reset)(avr_t *avr);

/* The cycles a frame takes with UBRR0, U2X0 and the frame format as they are. */
static avr_cycle_count_t frame_cycles(avr_t *avr)
{
	static const uint8_t data_bits[8] = { 5, 6, 7, 8, 8, 8, 8, 9 };	/* 4-6 reserved */
	uint32_t ubrr = avr_regbit_get(avr, u->ubrrl) | (uint32_t)avr_regbit_get(avr, u->ubrrh) << 8;
	uint32_t bit = (ubrr + 1) * (avr_regbit_get(avr, u->u2x) ? 8u : 16u);
	unsigned bits = 1u + data_bits[avr_regbit_get(avr, u->ucsz) | avr_regbit_get(avr, u->ucsz2) << 2]
		+ ((avr->data[u->r_ucsrc] >> UPM01) & 1u) + 1u + avr_regbit_get(avr, u->usbs);
	return (avr_cycle_count_t)bit * bits;
}

/* A UART condition is gone (UDR0 full: UDRE0; nothing left to read: RXC0): its flag
 * clear, and its interrupt not due.  simavr's avr_clear_interrupt() only marks the vector
 * not pending and leaves it queued in the pending interrupt FIFO (64 entries), where each
 * byte moved with interrupts off (the frame loops at 2 Mbaud) would leave one more: it is
 * taken out. */
static void unpend(avr_t *avr, avr_int_vector_t *vector)
{
	avr_int_pending_t *q = &avr->interrupts.pending;
	for (int n = avr_int_pending_get_read_size(q); n > 0; n--) {
		avr_int_vector_p v = avr_int_pending_read(q);
		if (v != vector)
			avr_int_pending_write(q, v);
	}
	avr_clear_interrupt(avr, vector);
	if (avr->interrupt_state > 0 && !avr_has_pending_interrupts(avr))
		avr->interrupt_state = 0;
	avr_regbit_clear(avr, vector->raised);
}

/* After every write to a register the frame time depends on (simavr's own handler has
 * just set its 11-bit figure when it was UBRR0).  And
 * simavr's handlers for UCSR0A/B know nothing of UDR0 being full: turning UDRIE0 on
 * raised the UDRE interrupt then, and the interrupt's byte was lost (measured). */
static void on_format_write(avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq; (void)value; (void)param;
	u->cycles_per_byte = frame_cycles(g_avr);
	if (udr_full)
		unpend(g_avr, &u->udrc);
}

/* The byte enters the shift register: it goes out on the line now. */
static void shift_out(uint8_t v)
{
	shifting = 1;
	avr_raise_irq(u->io.irq + UART_IRQ_OUTPUT, v);
}

static avr_cycle_count_t frame_end(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)param;
	if (!udr_full) {
		shifting = 0;
		avr_raise_interrupt(avr, &u->txc);
		return 0;
	}
	udr_full = 0;
	shift_out(udr);
	avr_raise_interrupt(avr, &u->udrc);
	return when + frame_cycles(avr);	/* back to back: from the last frame's end */
}

/* Replaces simavr's UDR0 write handler. */
static void on_udr_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	(void)param;
	if (avr->gdb)
		avr_gdb_handle_watchpoints(avr, addr, AVR_GDB_WATCH_WRITE);
	if (!avr_regbit_get(avr, u->txen) || udr_full)
		return;		/* the chip ignores a write with TXEN0 off or UDRE0 clear */
	if (shifting) {
		udr = v;
		udr_full = 1;
		unpend(avr, &u->udrc);
		return;
	}
	u->cycles_per_byte = frame_cycles(avr);
	shift_out(v);
	avr_cycle_timer_register(avr, u->cycles_per_byte, frame_end, NULL);
	avr_raise_interrupt(avr, &u->udrc);	/* still empty: the interrupt is due again */
}

/* A received frame ends: its byte, taken from the client's, is in (RXC0 and its
 * interrupt), or lost if the receiver already holds three; the next starts at once if
 * the client sent more.  With the receiver off the byte stays with the client, as it
 * did with simavr's receiver, which drops what comes while RXEN0 is clear. */
static avr_cycle_count_t rx_frame_end(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)param;
	int byte = avr_regbit_get(avr, u->rxen) ? rx_take() : -1;
	if (byte < 0) {
		g_rx_busy = 0;
		return 0;
	}
	if (uart_fifo_get_read_size(&u->input) < RX_HELD) {
		uart_fifo_write(&u->input, (uint16_t)byte);
		avr_raise_interrupt(avr, &u->rxc);
	} else {
		avr_regbit_set(avr, u->dor);
	}
	if (rx_pending()) {
		rx_started();
		return when + frame_cycles(avr);	/* back to back: from the last frame's end */
	}
	g_rx_busy = 0;
	return 0;
}

void uart_timing_rx_start(avr_t *avr)
{
	if (g_rx_busy)
		return;
	g_rx_busy = 1;
	rx_started();
	avr_cycle_timer_register(avr, frame_cycles(avr), rx_frame_end, NULL);
}

/* Replaces simavr's UDR0 read handler: the oldest byte held; RXC0 stays set (and its
 * interrupt due again) while more are held.  Reading it clears DOR0. */
static uint8_t on_udr_read(avr_t *avr, avr_io_addr_t addr, void *param)
{
	(void)param;
	avr->data[addr] = uart_fifo_isempty(&u->input) ? 0 : (uint8_t)uart_fifo_read(&u->input);
	uint8_t v = avr_core_watch_read(avr, addr);	/* gdb's watchpoints, as simavr's handler */
	avr_regbit_clear(avr, u->dor);
	if (uart_fifo_isempty(&u->input))
		unpend(avr, &u->rxc);
	else
		avr_raise_interrupt(avr, &u->rxc);
	return v;
}

static void uart_timing_reset(avr_t *avr)
{
	if (core_reset)
		core_reset(avr);
	avr_cycle_timer_cancel(avr, frame_end, NULL);
	avr_cycle_timer_cancel(avr, rx_frame_end, NULL);
	shifting = udr_full = g_rx_busy = 0;
}

int uart_timing_setup(avr_t *avr, avr_uart_t *uart)
{
	u = uart;
	avr_io_addr_t udr_io = AVR_DATA_TO_IO(u->r_udr);
	if (avr->io[udr_io].w.param != u) {
		diag("UART0's UDR write handler is not simavr's own: cannot time it as the chip");
		return -1;
	}
	avr->io[udr_io].w.c = on_udr_write;
	avr->io[udr_io].r.c = on_udr_read;
	core_reset = avr->reset;
	avr->reset = uart_timing_reset;
	const avr_io_addr_t format[] = { u->ubrrl.reg, u->ubrrh.reg, u->r_ucsra, u->r_ucsrb, u->r_ucsrc };
	for (size_t i = 0; i < sizeof format / sizeof format[0]; i++) {
		avr_irq_t *irq = avr_iomem_getirq(avr, format[i], NULL, AVR_IOMEM_IRQ_ALL);
		irq->flags &= (uint8_t)~IRQ_FLAG_FILTERED;	/* a write of the same value too */
		avr_irq_register_notify(irq, on_format_write, NULL);
	}
	u->cycles_per_byte = frame_cycles(avr);
	return 0;
}
