/* The UART pump: client bytes into UART0 through an SPSC ring filled by the
 * reader thread; UART0's output collected and written to the client. */
#include "bridge.h"

#include <errno.h>
#include <poll.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

uint8_t rx_ring[RX_RING_SIZE];
atomic_size_t rx_head;	/* written by the reader thread */
atomic_size_t rx_tail;	/* written by the sim loop */

int g_fd = -1;		/* client: accepted socket or pty master */
int g_fd_is_socket;

/* Reads what the client sent into the ring: bytes read, 0 if none (or the
 * ring is full: then after a pause that lets the kernel buffers and TCP flow
 * control push back), -1 once the client has gone (EOF, EIO) or on error. */
ssize_t ring_read(void)
{
	size_t head = atomic_load_explicit(&rx_head, memory_order_relaxed);
	size_t tail = atomic_load_explicit(&rx_tail, memory_order_acquire);
	size_t space = RX_RING_SIZE - (head - tail);
	if (space == 0) {
		struct timespec ts = { 0, 100000 };
		nanosleep(&ts, NULL);
		return 0;
	}
	size_t idx = head % RX_RING_SIZE;
	size_t n = RX_RING_SIZE - idx;
	if (n > space)
		n = space;
	ssize_t r = read(g_fd, rx_ring + idx, n);
	if (r > 0) {
		if (g_timing)
			atomic_store(&g_read_ns, mono_ns());
		atomic_store_explicit(&rx_head, head + (size_t)r, memory_order_release);
		if (!g_sim_reads)
			wake_paced();
		return r;
	}
	if (r < 0 && (errno == EINTR || errno == EAGAIN))
		return 0;
	return -1;
}

/* --realtime: the sim thread reads the client itself, in its pacing waits (ppoll) and at
 * each pacing check, instead of a reader thread.  A request's bytes then reach the UART
 * after one wake-up, where the reader thread's and then its signal to the sim thread
 * took two (10-45 us more on a loaded host).  Never blocks. */
int g_sim_reads;

void sim_read_input(void)
{
	size_t used = atomic_load(&rx_head) - atomic_load(&rx_tail);
	if (used < RX_RING_SIZE && ring_read() < 0) {
		atomic_store(&g_peer_closed, 1);
		atomic_store(&g_attention, 1);
	}
}

void *reader_thread(void *arg)
{
	(void)arg;
	for (;;) {
		struct pollfd pfd = { .fd = g_fd, .events = POLLIN };
		if (poll(&pfd, 1, -1) < 0 && errno != EINTR)
			break;
		if (ring_read() < 0)
			break;
	}
	atomic_store(&g_peer_closed, 1);
	atomic_store(&g_attention, 1);
	wake_paced();
	return NULL;
}

avr_t *g_avr;
avr_uart_t *g_uart;		/* UART0 module, for rxen and byte time */
avr_watchdog_t *g_wdt;
avr_irq_t *g_uart_in;
int g_uart_xoff = 0;		/* UART input FIFO full */

uint8_t out_buf[1u << 16];
size_t out_len;
int out_flush_now;
avr_cycle_count_t out_last_cycle;
avr_cycle_count_t in_last_cycle;	/* last byte fed to the UART */

/* Sends to the client.  Waits while the client does not read (the
 * simulation then stalls, like a UART with flow control); gives up on
 * SIGINT/SIGTERM or when the client has gone.  g_fd is non-blocking. */
static void write_all(const uint8_t *p, size_t n)
{
	while (n && !atomic_load(&g_peer_closed) && !atomic_load(&g_stop_signal)) {
		if (opt.bootloader && !atomic_load(&g_attached))
			return;		/* nobody has the port open: the bytes go nowhere */
		ssize_t w = g_fd_is_socket ? send(g_fd, p, n, MSG_NOSIGNAL) : write(g_fd, p, n);
		if (w > 0) {
			p += w;
			n -= (size_t)w;
			continue;
		}
		if (w < 0 && (errno == EINTR || errno == EAGAIN)) {
			struct pollfd pfd = { .fd = g_fd, .events = POLLOUT };
			poll(&pfd, 1, 100);
			continue;
		}
		/* EPIPE, ECONNRESET, EIO (pty closed) ... */
		if (opt.bootloader)
			return;		/* the reader sees the hangup; the next client may come */
		atomic_store(&g_peer_closed, 1);
		atomic_store(&g_attention, 1);
		return;
	}
}

void out_flush(void)
{
	if (out_len && g_timing) {
		uint64_t start = mono_ns();
		write_all(out_buf, out_len);
		timing_out(out_len, start, mono_ns());
	} else if (out_len) {
		write_all(out_buf, out_len);
	}
	out_len = 0;
	out_flush_now = 0;
}

void on_uart_output(avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq; (void)param;
	if (out_len == sizeof out_buf)
		out_flush();
	out_buf[out_len++] = (uint8_t)value;
	out_last_cycle = g_avr->cycle;
	if ((uint8_t)value == 0)
		out_flush_now = 1;	/* end of a COBS frame: send it now */
	if (g_sig) {
		avr_raise_irq(g_sig + SIG_TX, value & 0xff);
		avr_raise_irq(g_sig + SIG_TX_STB, !g_sig[SIG_TX_STB].value);
	}
}

void on_uart_xon(avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq; (void)value; (void)param;
	g_uart_xoff = 0;
	if (g_sig)
		avr_raise_irq(g_sig + SIG_XOFF, 0);
}

void on_uart_xoff(avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq; (void)param;
	g_uart_xoff = value ? 1 : 0;
	if (g_sig)
		avr_raise_irq(g_sig + SIG_XOFF, g_uart_xoff);
}

static int uart_rx_enabled(void)
{
	return g_uart ? avr_regbit_get(g_avr, g_uart->rxen) : 1;
}

/* Moves ring bytes into the UART while it wants them: with the chip's timing
 * (uart_timing.c), one a frame as its receiver takes them (rx_take). */
void feed_uart(void)
{
	if (!uart_rx_enabled())
		return;		/* simavr silently drops bytes while RXEN=0 */
	if (atomic_load(&g_reset_request))
		return;		/* a new client's bytes are for the chip after its reset */
	if (!opt.simavr_uart) {
		uart_timing_rx_start(g_avr);
		return;
	}
	size_t tail = atomic_load_explicit(&rx_tail, memory_order_relaxed);
	size_t head = atomic_load_explicit(&rx_head, memory_order_acquire);
	size_t first = tail;
	while (tail != head && !g_uart_xoff) {
		uint8_t b = rx_ring[tail % RX_RING_SIZE];
		tail++;
		avr_raise_irq(g_uart_in, b);
		in_last_cycle = g_avr->cycle;
	}
	atomic_store_explicit(&rx_tail, tail, memory_order_release);
	if (g_timing && tail != first)
		timing_in(tail - first);
}

/* The next byte for the UART, or -1 if there is none (or a reset is due first). */
int rx_take(void)
{
	size_t tail = atomic_load_explicit(&rx_tail, memory_order_relaxed);
	if (tail == atomic_load_explicit(&rx_head, memory_order_acquire) || atomic_load(&g_reset_request))
		return -1;
	uint8_t b = rx_ring[tail % RX_RING_SIZE];
	atomic_store_explicit(&rx_tail, tail + 1, memory_order_release);
	in_last_cycle = g_avr->cycle;
	return b;
}

/* --timing: a byte starts in; the bytes the client had sent by then, from this one on,
 * are one `in` line, unless an earlier line counted this byte already. */
void rx_started(void)
{
	static size_t logged;	/* ring index up to which `in` lines counted the bytes */
	size_t tail = atomic_load_explicit(&rx_tail, memory_order_relaxed);
	if (!g_timing || tail < logged)
		return;
	logged = atomic_load_explicit(&rx_head, memory_order_acquire);
	timing_in(logged - tail);
}

int rx_pending(void)
{
	return atomic_load_explicit(&rx_head, memory_order_relaxed)
		!= atomic_load_explicit(&rx_tail, memory_order_relaxed);
}

/* Input the UART can take now: a reason to end a realtime wait. */
int input_wakes(void)
{
	return rx_pending() && !g_uart_xoff && uart_rx_enabled();
}
