/*
 * vehil-simavr: run an AVR firmware ELF under simavr and bridge its UART0 to
 * a host program, over a loopback TCP socket or a pseudo-terminal.
 *
 *   vehil-simavr [options] FIRMWARE.elf
 *   vehil-simavr [options] --bootloader BOOT.hex [--flash-image FILE]
 *
 * The second form is a chip with a bootloader and nothing else: flash erased,
 * BOOT.hex in the boot section, the reset vector on it (BOOTRST).  Whatever
 * the bootloader writes with SPM is what runs.  Every client that opens the
 * pty resets the chip, as opening the port resets a Mega (DTR), and the flash
 * outlives the reset (and the process, with --flash-image).
 *
 * Exactly one line goes to stdout, once the bridge is ready for its client:
 *   vehil-simavr: listening url=socket://127.0.0.1:PORT
 *   vehil-simavr: listening url=/dev/pts/N
 * Everything else (diagnostics, simavr's own chatter) goes to stderr.
 *
 * Threads: simavr is not thread-safe, so everything that touches the AVR runs
 * on the main thread (the "sim loop").  One reader thread blocks in read() on
 * the client fd and pushes bytes into a single-producer/single-consumer ring;
 * the sim loop pops them into the UART's input IRQ only while the UART has
 * room (its XON/XOFF IRQs) and the receiver is enabled.  Bytes the firmware
 * transmits are collected by the sim loop and written to the client when a
 * frame delimiter (0x00) goes out, when the line has been idle for two byte
 * times, or when the buffer fills.
 *
 * Exit codes: 0 clean stop (SIGINT/SIGTERM, client disconnected, cycle
 * limit), 1 setup error (ELF, socket, pty...), 2 usage error, 3 firmware
 * crashed (simavr cpu_Crashed, invalid opcode, invalid memory access),
 * 4 firmware halted (SLEEP with interrupts off, or a jump-to-self loop with
 * interrupts off and no watchdog).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <limits.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <arpa/inet.h>
#include <poll.h>
#include <pthread.h>
#include <pty.h>
#include <signal.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/inotify.h>
#include <sys/ioctl.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <gelf.h>
#include <libelf.h>

#include <sim_avr.h>
#include <sim_elf.h>
#include <sim_gdb.h>
#include <sim_vcd_file.h>
#include <avr_uart.h>
#include <avr_ioport.h>
#include <avr_watchdog.h>

#define PROG "vehil-simavr"

enum {
	EXIT_CLEAN = 0,
	EXIT_SETUP = 1,
	EXIT_USAGE = 2,
	EXIT_CRASH = 3,
	EXIT_HALT = 4,
};

enum transport { TR_TCP, TR_PTY };
/* Default transport (see sim/README.md): as fast as TCP, loss-free, and the
 * CPU can start exactly when pyserial's open() is done (no fixed delay). */
#define DEFAULT_TRANSPORT TR_PTY

/* ------------------------------------------------------------------------ */
/* options */

static struct {
	enum transport transport;
	int tcp_port;
	const char *mcu;
	uint32_t freq;
	const char *vcd;
	int gdb_port;		/* -1: off */
	int realtime;
	uint64_t cycles_limit;	/* 0: none */
	int log_level;
	unsigned start_delay_ms;
	const char *elf;
	const char *bootloader;		/* Intel HEX; NULL: run the ELF */
	const char *flash_image;	/* with --bootloader: flash kept here */
} opt = {
	.transport = DEFAULT_TRANSPORT,
	.tcp_port = 0,
	.mcu = "atmega2560",
	.freq = 16000000,
	.gdb_port = -1,
	.log_level = LOG_ERROR,
	.start_delay_ms = 100,
};

/* ------------------------------------------------------------------------ */
/* diagnostics */

static void diag(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static void diag(const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	fputs(PROG ": ", stderr);
	vfprintf(stderr, fmt, ap);
	fputc('\n', stderr);
	va_end(ap);
}

/* Anything that must stop the sim loop sets g_attention; the loop then
 * looks at the individual flags.  All of these are lock-free atomics, so the
 * signal handler and the reader thread may set them. */
static atomic_int g_attention;
static atomic_int g_stop_signal;	/* signal number, 0 if none */
static atomic_int g_peer_closed;
static int g_fault;			/* set by the logger, sim thread only */
static char g_fault_msg[256];

static void on_signal(int sig)
{
	atomic_store(&g_stop_signal, sig);
	atomic_store(&g_attention, 1);
}

/* Copies a simavr log message without its ANSI colour codes and newline. */
static void strip_msg(char *dst, size_t n, const char *src)
{
	size_t j = 0;
	for (size_t i = 0; src[i] && j + 1 < n; i++) {
		if (src[i] == '\033') {
			while (src[i] && src[i] != 'm')
				i++;
			if (!src[i])
				break;
			continue;
		}
		if (src[i] == '\n' || src[i] == '\r')
			continue;
		dst[j++] = src[i];
	}
	dst[j] = 0;
}

/* simavr's default logger prints warnings and traces to stdout, which must
 * carry only our one line: route everything to stderr, and treat the
 * core's "Invalid Opcode" / "Invalid read|write address" reports as a crash
 * (simavr itself only logs them and carries on). */
static void sim_logger(avr_t *avr, const int level, const char *fmt, va_list ap)
{
	char raw[512], msg[256];
	vsnprintf(raw, sizeof raw, fmt, ap);
	strip_msg(msg, sizeof msg, raw);
	if (strstr(fmt, "Invalid Opcode") || strstr(fmt, "Invalid write address")
			|| strstr(fmt, "Invalid read address")) {
		if (!g_fault) {
			g_fault = 1;
			snprintf(g_fault_msg, sizeof g_fault_msg, "%s", msg);
			atomic_store(&g_attention, 1);
		}
		return;		/* reported by the sim loop */
	}
	if (strstr(msg, "avr_sadly_crashed"))
		return;		/* reported by the sim loop, with more context */
	int cur = avr ? avr->log : opt.log_level;
	if (level <= cur && msg[0])
		fprintf(stderr, PROG ": simavr: %s\n", msg);
}

/* ------------------------------------------------------------------------ */
/* time */

static uint64_t mono_ns(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

static uint64_t cycles_to_ns(uint64_t c, uint32_t f)
{
	return (c / f) * 1000000000u + (c % f) * 1000000000u / f;
}

static uint64_t ns_to_cycles(uint64_t ns, uint32_t f)
{
	return (ns / 1000000000u) * f + (ns % 1000000000u) * f / 1000000000u;
}

/* ------------------------------------------------------------------------ */
/* client -> UART: SPSC ring filled by the reader thread */

#define RX_RING_SIZE (1u << 16)
static uint8_t rx_ring[RX_RING_SIZE];
static atomic_size_t rx_head;	/* written by the reader thread */
static atomic_size_t rx_tail;	/* written by the sim loop */

static int g_fd = -1;		/* client: accepted socket or pty master */
static int g_fd_is_socket;

/* realtime mode: the sim loop may wait for wall-clock time; new input wakes it */
static pthread_mutex_t rt_lock = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t rt_cond;

static void wake_paced(void)
{
	if (opt.realtime || opt.bootloader) {	/* the sim loop may be waiting */
		pthread_mutex_lock(&rt_lock);
		pthread_cond_signal(&rt_cond);
		pthread_mutex_unlock(&rt_lock);
	}
}

/* Reads what the client sent into the ring: bytes read, 0 if none (or the
 * ring is full: then after a pause that lets the kernel buffers and TCP flow
 * control push back), -1 once the client has gone (EOF, EIO) or on error. */
static ssize_t ring_read(void)
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
		atomic_store_explicit(&rx_head, head + (size_t)r, memory_order_release);
		wake_paced();
		return r;
	}
	if (r < 0 && (errno == EINTR || errno == EAGAIN))
		return 0;
	return -1;
}

static void *reader_thread(void *arg)
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

/* Bootloader mode: clients come and go, and each open of the pty resets the
 * chip, as opening a Mega's port does (DTR).  inotify reports the opens (the
 * master sees none, and misses a close that a quick reopen follows); the
 * master's POLLHUP says nobody has the port open, and output is dropped. */
static int g_inotify = -1;
static atomic_int g_reset_request;
static atomic_size_t g_open_mark;	/* rx_head when the port was opened */
static atomic_int g_attached;		/* someone has the pty open */
static atomic_int g_client_left;

static void *boot_reader_thread(void *arg)
{
	(void)arg;
	for (;;) {
		int attached = atomic_load(&g_attached);
		struct pollfd p[2] = {
			{ .fd = g_inotify, .events = POLLIN },
			{ .fd = g_fd, .events = POLLIN },
		};
		if (poll(p, attached ? 2 : 1, -1) < 0) {
			if (errno == EINTR)
				continue;
			break;
		}
		if (p[0].revents & POLLIN) {
			/* only IN_OPEN is watched: every event is an open */
			char ev[4096] __attribute__((aligned(__alignof__(struct inotify_event))));
			if (read(g_inotify, ev, sizeof ev) > 0) {
				/* mark first: feed_uart holds what follows until the reset */
				atomic_store(&g_open_mark, atomic_load(&rx_head));
				atomic_store(&g_reset_request, 1);
				atomic_store(&g_attached, 1);
				atomic_store(&g_attention, 1);
				wake_paced();
			}
			continue;
		}
		if (!attached)
			continue;
		if ((p[1].revents & POLLIN) && ring_read() >= 0)
			continue;
		if (p[1].revents & (POLLIN | POLLHUP | POLLERR)) {
			atomic_store(&g_attached, 0);
			atomic_store(&g_client_left, 1);
			atomic_store(&g_attention, 1);
			wake_paced();
		}
	}
	diag("lost the pty: %s", strerror(errno));
	atomic_store(&g_peer_closed, 1);
	atomic_store(&g_attention, 1);
	return NULL;
}

/* ------------------------------------------------------------------------ */
/* UART glue (sim thread only) */

static avr_t *g_avr;
static avr_uart_t *g_uart;		/* UART0 module, for rxen and byte time */
static avr_watchdog_t *g_wdt;
static avr_irq_t *g_uart_in;
static int g_uart_xoff = 0;		/* UART input FIFO full */

static uint8_t out_buf[1u << 16];
static size_t out_len;
static int out_flush_now;
static avr_cycle_count_t out_last_cycle;
static avr_cycle_count_t in_last_cycle;	/* last byte fed to the UART */

/* extra VCD signals */
enum { SIG_TX, SIG_TX_STB, SIG_RX, SIG_RX_STB, SIG_XOFF, SIG_SLEEP, SIG_COUNT };
static const char *sig_names[SIG_COUNT] = {
	[SIG_TX] = "8>uart0_tx", [SIG_TX_STB] = "1>uart0_tx_strobe",
	[SIG_RX] = "8>uart0_rx", [SIG_RX_STB] = "1>uart0_rx_strobe",
	[SIG_XOFF] = "1>uart0_xoff", [SIG_SLEEP] = "1>cpu_sleeping",
};
static avr_irq_t *g_sig;		/* NULL unless --vcd */
static avr_vcd_t g_vcd;
static int g_vcd_open;

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

static void out_flush(void)
{
	if (out_len)
		write_all(out_buf, out_len);
	out_len = 0;
	out_flush_now = 0;
}

static void on_uart_output(avr_irq_t *irq, uint32_t value, void *param)
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

static void on_uart_xon(avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq; (void)value; (void)param;
	g_uart_xoff = 0;
	if (g_sig)
		avr_raise_irq(g_sig + SIG_XOFF, 0);
}

static void on_uart_xoff(avr_irq_t *irq, uint32_t value, void *param)
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

/* Moves ring bytes into the UART while it wants them. */
static void feed_uart(void)
{
	if (!uart_rx_enabled())
		return;		/* simavr silently drops bytes while RXEN=0 */
	size_t tail = atomic_load_explicit(&rx_tail, memory_order_relaxed);
	size_t head = atomic_load_explicit(&rx_head, memory_order_acquire);
	if (atomic_load(&g_reset_request))
		return;		/* a new client's bytes are for the chip after its reset */
	while (tail != head && !g_uart_xoff) {
		uint8_t b = rx_ring[tail % RX_RING_SIZE];
		tail++;
		avr_raise_irq(g_uart_in, b);
		in_last_cycle = g_avr->cycle;
	}
	atomic_store_explicit(&rx_tail, tail, memory_order_release);
}

static int rx_pending(void)
{
	return atomic_load_explicit(&rx_head, memory_order_relaxed)
		!= atomic_load_explicit(&rx_tail, memory_order_relaxed);
}

/* Input the UART can take now: a reason to end a realtime wait. */
static int input_wakes(void)
{
	return rx_pending() && !g_uart_xoff && uart_rx_enabled();
}

/* ------------------------------------------------------------------------ */
/* sleep handling and realtime pacing */

static uint64_t rt_base_ns;		/* wall clock at rt_base_cycle */
static avr_cycle_count_t rt_base_cycle;

/* Waits until the monotonic clock reaches deadline, or input for the UART
 * arrives, or something needs attention.  Returns early in the last two
 * cases.  (Runs on the sim thread; the reader thread signals rt_cond.) */
static void rt_wait(uint64_t deadline)
{
	struct timespec ts = { (time_t)(deadline / 1000000000u), (long)(deadline % 1000000000u) };
	pthread_mutex_lock(&rt_lock);
	while (!input_wakes() && !atomic_load(&g_attention)) {
		if (pthread_cond_timedwait(&rt_cond, &rt_lock, &ts) == ETIMEDOUT)
			break;
	}
	pthread_mutex_unlock(&rt_lock);
}

/* Free-running: a sleeping CPU just skips ahead to the next timer. */
static void sleep_free(avr_t *avr, avr_cycle_count_t howlong)
{
	(void)avr; (void)howlong;
}

/* Realtime: wait for the wall clock to reach the end of the sleep; if input
 * arrives first, only advance simulated time up to "now" (the caller adds
 * howlong + 1 to avr->cycle after we return, so we take the rest back). */
static void sleep_realtime(avr_t *avr, avr_cycle_count_t howlong)
{
	avr_cycle_count_t target = avr->cycle + howlong;
	uint64_t deadline = rt_base_ns + cycles_to_ns(target - rt_base_cycle, avr->frequency);
	if (mono_ns() < deadline && !input_wakes())
		rt_wait(deadline);
	uint64_t now = mono_ns();
	if (now >= deadline)
		return;
	avr_cycle_count_t reached = rt_base_cycle + ns_to_cycles(now - rt_base_ns, avr->frequency);
	avr_cycle_count_t done = reached > avr->cycle ? reached - avr->cycle : 0;
	if (done < howlong)
		avr->cycle -= howlong - done;
}

/* Realtime, CPU running: never let simulated time get ahead of wall time. */
static void rt_pace(avr_t *avr)
{
	uint64_t sim = rt_base_ns + cycles_to_ns(avr->cycle - rt_base_cycle, avr->frequency);
	if (sim > mono_ns())
		rt_wait(sim);
}

/* ------------------------------------------------------------------------ */
/* halting detection */

/* A firmware that returned from main (avr-libc: cli; rjmp .-0) or otherwise
 * spins on a jump-to-self with interrupts off can never do anything again,
 * unless the watchdog is armed. */
static int halted_in_dead_loop(avr_t *avr)
{
	if (avr->state != cpu_Running || avr->sreg[S_I])
		return 0;
	if (avr->pc + 1 > avr->flashend)
		return 0;
	uint16_t op = (uint16_t)(avr->flash[avr->pc] | (avr->flash[avr->pc + 1] << 8));
	if (op != 0xcfff)	/* rjmp .-2 */
		return 0;
	if (g_wdt && (avr_regbit_get(avr, g_wdt->wde) || avr_regbit_get(avr, g_wdt->watchdog.enable)))
		return 0;
	return 1;
}

/* ------------------------------------------------------------------------ */
/* bootloader mode: a chip that is programmed through its bootloader */

static avr_flashaddr_t g_boot_start;	/* byte address of the bootloader */

static int hex_digit(char c)
{
	if (c >= '0' && c <= '9')
		return c - '0';
	if (c >= 'A' && c <= 'F')
		return c - 'A' + 10;
	if (c >= 'a' && c <= 'f')
		return c - 'a' + 10;
	return -1;
}

/* Reads an Intel HEX file into mem (records 00, 01, 02, 04; the start
 * address records 03 and 05 are ignored: the reset vector decides).
 * simavr's own reader knows no type 02 record, which avr-gcc writes for the
 * Mega's bootloader.  Returns 0 with the lowest address loaded in *lo, or -1
 * after saying what is wrong and where. */
static int load_ihex(const char *path, uint8_t *mem, uint32_t size, uint32_t *lo)
{
	FILE *f = fopen(path, "r");
	if (!f) {
		diag("cannot load bootloader '%s': %s", path,
			errno == ENOENT ? "no such file" : strerror(errno));
		return -1;
	}
	char line[1024];
	uint32_t base = 0;
	unsigned lineno = 0;
	int end = 0, loaded = 0;
	*lo = UINT32_MAX;
	while (!end && fgets(line, sizeof line, f)) {
		lineno++;
		size_t n = strcspn(line, "\r\n");
		if (n == 0)
			continue;
		uint8_t rec[(sizeof line - 1) / 2];
		size_t len = (n - 1) / 2;
		unsigned sum = 0;
		int ok = line[0] == ':' && n >= 11 && (n - 1) % 2 == 0;
		for (size_t i = 0; ok && i < len; i++) {
			int h = hex_digit(line[1 + 2 * i]), l = hex_digit(line[2 + 2 * i]);
			ok = h >= 0 && l >= 0;
			rec[i] = (uint8_t)(h << 4 | l);
			sum += rec[i];
		}
		if (!ok || rec[0] + 5u != len || (sum & 0xff)) {
			diag("cannot load bootloader '%s': line %u is not an Intel HEX record "
				"(or its checksum is wrong)", path, lineno);
			fclose(f);
			return -1;
		}
		uint32_t addr = base + ((uint32_t)rec[1] << 8 | rec[2]);
		switch (rec[3]) {
		case 0:
			if (addr + rec[0] > size) {
				diag("cannot load bootloader '%s': line %u writes 0x%05x, past the end "
					"of the %u bytes of flash", path, lineno, (unsigned)(addr + rec[0] - 1),
					(unsigned)size);
				fclose(f);
				return -1;
			}
			memcpy(mem + addr, rec + 4, rec[0]);
			if (addr < *lo)
				*lo = addr;
			loaded = 1;
			break;
		case 1:
			end = 1;
			break;
		case 2:		/* extended segment address: bits 4..19 */
			base = ((uint32_t)rec[4] << 8 | rec[5]) << 4;
			break;
		case 4:		/* extended linear address: bits 16..31 */
			base = ((uint32_t)rec[4] << 8 | rec[5]) << 16;
			break;
		case 3:
		case 5:
			break;
		default:
			diag("cannot load bootloader '%s': line %u has record type %u, not Intel HEX",
				path, lineno, rec[3]);
			fclose(f);
			return -1;
		}
	}
	fclose(f);
	if (!loaded) {
		diag("cannot load bootloader '%s': no data records", path);
		return -1;
	}
	return 0;
}

/* The whole flash as a raw file: what a later run starts from. */
static int load_flash_image(avr_t *avr, const char *path)
{
	FILE *f = fopen(path, "rb");
	if (!f && errno == ENOENT)
		return 0;	/* none yet: erased flash */
	if (!f) {
		diag("cannot read flash image '%s': %s", path, strerror(errno));
		return -1;
	}
	size_t n = fread(avr->flash, 1, avr->flashend + 1, f);
	int extra = fgetc(f) != EOF;
	fclose(f);
	if (n != avr->flashend + 1 || extra) {
		diag("flash image '%s' is not %u bytes (the %s's flash); delete it to start erased",
			path, (unsigned)avr->flashend + 1, opt.mcu);
		return -1;
	}
	return 0;
}

/* Written to a temporary file and renamed, so a kill mid-write leaves the
 * previous image, never half of one. */
static void save_flash_image(avr_t *avr)
{
	if (!opt.flash_image)
		return;
	char tmp[PATH_MAX];
	snprintf(tmp, sizeof tmp, "%s.tmp", opt.flash_image);
	FILE *f = fopen(tmp, "wb");
	int ok = f && fwrite(avr->flash, 1, avr->flashend + 1, f) == avr->flashend + 1;
	if (f && fclose(f) != 0)
		ok = 0;
	if (!ok || rename(tmp, opt.flash_image) != 0)
		diag("cannot save the flash to '%s': %s", opt.flash_image, strerror(errno));
}

/* The bootloader gives up on the host after a timeout: about a second after
 * a reset (then it starts the application), and again mid-session.
 * Free-running, a second passes in ~0.08 s of wall time: before avrdude (which
 * spends 0.1 s pulsing DTR) has said a word, or whenever a loaded host pauses.
 * So once the CPU has been in the boot section with the line quiet both ways
 * for 10 ms, simulated time keeps to wall time, and the timeouts last as on a
 * chip (10 ms longer at most).  Between bytes and pages it runs free:
 * programming is not slowed down. */
static int g_boot_paced;

static void boot_pace(avr_t *avr)
{
	avr_cycle_count_t last = in_last_cycle > out_last_cycle ? in_last_cycle : out_last_cycle;
	/* the UART's FIFO accessors are not exported: compare its cursors */
	int waiting = avr->pc >= g_boot_start && !rx_pending() && out_len == 0
		&& (!g_uart || g_uart->input.read == g_uart->input.write)
		&& avr->cycle - last > avr->frequency / 100;
	if (waiting && !g_boot_paced) {	/* wall time starts now, not at the last pacing */
		rt_base_ns = mono_ns();
		rt_base_cycle = avr->cycle;
	}
	g_boot_paced = waiting;
	if (waiting)
		rt_pace(avr);
}

/* ------------------------------------------------------------------------ */
/* setup helpers */

static FILE *g_stdout;		/* the real stdout; fd 1 points at stderr */

static void usage(FILE *f)
{
	fprintf(f,
"usage: " PROG " [options] FIRMWARE.elf\n"
"       " PROG " [options] --bootloader BOOT.hex [--flash-image FILE]\n"
"\n"
"Runs FIRMWARE.elf in simavr and bridges UART0 to one client.\n"
"With --bootloader, the chip starts with erased flash and BOOT.hex in its\n"
"boot section, at the reset vector: it runs what the bootloader writes.\n"
"Each client that opens the pty resets the chip (a Mega resets when its\n"
"port is opened); the bridge serves one client after another.\n"
"Prints one line to stdout when ready for the client:\n"
"  " PROG ": listening url=/dev/pts/N                (--pty)\n"
"  " PROG ": listening url=socket://127.0.0.1:PORT   (--tcp)\n"
"The CPU starts only once the client is connected (see --start-delay).\n"
"\n"
"options:\n"
"  --pty              serve UART0 on a new pseudo-terminal (the default)\n"
"  --tcp PORT         serve UART0 on 127.0.0.1:PORT, one client (0 = pick a\n"
"                     free port)\n"
"  --mcu NAME         simavr core name (default atmega2560)\n"
"  --freq HZ          CPU clock (default 16000000)\n"
"  --realtime         keep simulated time from running ahead of wall time\n"
"                     (default: run as fast as possible, SLEEP skips ahead)\n"
"  --cycles-limit N   stop cleanly after N CPU cycles\n"
"  --vcd FILE         write a VCD trace: UART0 bytes written to / read from\n"
"                     UDR0 (with strobes that toggle per byte), UART0 input\n"
"                     FIFO full (xoff), CPU sleeping, output pins of each port\n"
"  --gdb PORT         start simavr's gdb server on PORT and wait for gdb\n"
"  --bootloader HEX   boot from this Intel HEX bootloader, flash erased\n"
"  --flash-image FILE with --bootloader: start from this raw flash image if it\n"
"                     exists, and write the flash to it when a client leaves\n"
"                     and at exit\n"
"  --start-delay MS   after a TCP client connects, wait MS before starting the\n"
"                     CPU (pyserial's open() discards input that arrives while\n"
"                     it opens); with --pty, start as soon as the client has\n"
"                     flushed its input, or at the latest MS after it opened\n"
"                     (default 100; 0 for clients that do not flush)\n"
"  -v, --verbose      more simavr logging (repeatable)\n"
"  -q, --quiet        no simavr logging\n"
"  -h, --help         this help\n"
"\n"
"exit status: 0 clean stop (SIGINT/SIGTERM, client disconnected, cycle limit),\n"
"1 setup error, 2 usage error, 3 firmware crashed, 4 firmware halted\n"
"(SLEEP with interrupts off, or cli + jump-to-self).\n");
}

static int parse_u64(const char *s, uint64_t *v)
{
	char *end;
	errno = 0;
	if (!*s || *s == '-')
		return -1;
	unsigned long long x = strtoull(s, &end, 0);
	if (errno || *end)
		return -1;
	*v = x;
	return 0;
}

static void parse_args(int argc, char **argv)
{
	enum { O_TCP = 256, O_PTY, O_MCU, O_FREQ, O_RT, O_LIMIT, O_VCD, O_GDB, O_DELAY, O_BOOT, O_IMAGE };
	static const struct option lo[] = {
		{ "tcp", required_argument, NULL, O_TCP },
		{ "pty", no_argument, NULL, O_PTY },
		{ "mcu", required_argument, NULL, O_MCU },
		{ "freq", required_argument, NULL, O_FREQ },
		{ "realtime", no_argument, NULL, O_RT },
		{ "cycles-limit", required_argument, NULL, O_LIMIT },
		{ "vcd", required_argument, NULL, O_VCD },
		{ "gdb", required_argument, NULL, O_GDB },
		{ "start-delay", required_argument, NULL, O_DELAY },
		{ "bootloader", required_argument, NULL, O_BOOT },
		{ "flash-image", required_argument, NULL, O_IMAGE },
		{ "verbose", no_argument, NULL, 'v' },
		{ "quiet", no_argument, NULL, 'q' },
		{ "help", no_argument, NULL, 'h' },
		{ 0, 0, 0, 0 },
	};
	int c, n_transport = 0;
	uint64_t v;
	opterr = 0;	/* our own messages */
	while ((c = getopt_long(argc, argv, "vqh", lo, NULL)) != -1) {
		switch (c) {
		case O_TCP:
			if (parse_u64(optarg, &v) || v > 65535) {
				diag("--tcp: bad port '%s'", optarg);
				exit(EXIT_USAGE);
			}
			opt.transport = TR_TCP;
			opt.tcp_port = (int)v;
			n_transport++;
			break;
		case O_PTY:
			opt.transport = TR_PTY;
			n_transport++;
			break;
		case O_MCU:
			opt.mcu = optarg;
			break;
		case O_FREQ:
			if (parse_u64(optarg, &v) || v < 1000 || v > 1000000000) {
				diag("--freq: bad frequency '%s' (Hz)", optarg);
				exit(EXIT_USAGE);
			}
			opt.freq = (uint32_t)v;
			break;
		case O_RT:
			opt.realtime = 1;
			break;
		case O_LIMIT:
			if (parse_u64(optarg, &v) || v == 0) {
				diag("--cycles-limit: bad count '%s'", optarg);
				exit(EXIT_USAGE);
			}
			opt.cycles_limit = v;
			break;
		case O_VCD:
			opt.vcd = optarg;
			break;
		case O_GDB:
			if (parse_u64(optarg, &v) || v == 0 || v > 65535) {
				diag("--gdb: bad port '%s'", optarg);
				exit(EXIT_USAGE);
			}
			opt.gdb_port = (int)v;
			break;
		case O_DELAY:
			if (parse_u64(optarg, &v) || v > 60000) {
				diag("--start-delay: bad milliseconds '%s'", optarg);
				exit(EXIT_USAGE);
			}
			opt.start_delay_ms = (unsigned)v;
			break;
		case O_BOOT:
			opt.bootloader = optarg;
			break;
		case O_IMAGE:
			opt.flash_image = optarg;
			break;
		case 'v':
			if (opt.log_level < LOG_DEBUG)
				opt.log_level++;
			break;
		case 'q':
			opt.log_level = LOG_NONE;
			break;
		case 'h':
			usage(g_stdout);
			fflush(g_stdout);
			exit(EXIT_CLEAN);
		default:
			if (optopt && optopt < 256 && optopt != '?')
				diag("option -%c needs an argument or is unknown", optopt);
			else
				diag("unknown option or missing argument: '%s'", argv[optind - 1]);
			fprintf(stderr, "try '" PROG " --help'\n");
			exit(EXIT_USAGE);
		}
	}
	if (n_transport > 1) {
		diag("give only one of --tcp and --pty");
		exit(EXIT_USAGE);
	}
	if (opt.flash_image && !opt.bootloader) {
		diag("--flash-image needs --bootloader");
		exit(EXIT_USAGE);
	}
	if (opt.bootloader && opt.transport != TR_PTY) {
		/* a new client must reset the chip: only the pty shows who opens it */
		diag("--bootloader serves a pty only, not --tcp");
		exit(EXIT_USAGE);
	}
	int want = opt.bootloader ? 0 : 1;
	if (argc - optind != want) {
		diag(opt.bootloader ? "--bootloader runs no FIRMWARE.elf: drop it"
			: optind >= argc ? "missing FIRMWARE.elf" : "too many arguments");
		usage(stderr);
		exit(EXIT_USAGE);
	}
	if (!opt.bootloader)
		opt.elf = argv[optind];
}

/* Checks that the file exists and is a 32-bit AVR ELF before handing it to
 * simavr, whose loader gives poor messages (or none) on bad input. */
static void check_elf_file(const char *path)
{
	struct stat st;
	if (stat(path, &st) != 0) {
		diag("cannot load firmware '%s': %s", path,
			errno == ENOENT ? "no such file" : strerror(errno));
		exit(EXIT_SETUP);
	}
	if (!S_ISREG(st.st_mode)) {
		diag("cannot load firmware '%s': not a regular file", path);
		exit(EXIT_SETUP);
	}
	int fd = open(path, O_RDONLY | O_CLOEXEC);
	if (fd < 0) {
		diag("cannot load firmware '%s': %s", path, strerror(errno));
		exit(EXIT_SETUP);
	}
	unsigned char h[20];
	ssize_t n = read(fd, h, sizeof h);
	close(fd);
	if (n < (ssize_t)sizeof h || memcmp(h, "\177ELF", 4) != 0) {
		diag("cannot load firmware '%s': not an ELF file", path);
		exit(EXIT_SETUP);
	}
	if (h[4] != 1 || h[5] != 1) {
		diag("cannot load firmware '%s': not a 32-bit little-endian ELF (built for the host?)", path);
		exit(EXIT_SETUP);
	}
	unsigned type = h[16] | (h[17] << 8);
	unsigned machine = h[18] | (h[19] << 8);
	if (machine != 83 /* EM_AVR */) {
		diag("cannot load firmware '%s': ELF machine is %u, not AVR (83)", path, machine);
		exit(EXIT_SETUP);
	}
	if (type != 2 /* ET_EXEC */) {
		diag("cannot load firmware '%s': not a linked executable (ELF type %u%s)", path, type,
			type == 1 ? ", a relocatable object file" : "");
		exit(EXIT_SETUP);
	}
}

/* The flash image as the chip gets it: every loadable segment at its load
 * address.  simavr 1.6 builds flash from the sections named .text and .data,
 * one after the other; vehil's linker script loads .data between the start-up
 * code and the rest (so QEMU 7.2 can read it below 64 KB), which that misses.
 * Returns 0, or -1 with a message. */
static int load_flash_segments(const char *path, elf_firmware_t *fw)
{
	int fd = open(path, O_RDONLY | O_CLOEXEC);
	if (fd < 0 || elf_version(EV_CURRENT) == EV_NONE) {
		diag("cannot load firmware '%s': %s", path, fd < 0 ? strerror(errno) : "libelf");
		return -1;
	}
	Elf *elf = elf_begin(fd, ELF_C_READ, NULL);
	size_t n = 0;
	int rc = -1;
	if (!elf || elf_getphdrnum(elf, &n) != 0) {
		diag("cannot load firmware '%s': no program headers: %s", path, elf_errmsg(-1));
		goto out;
	}
	uint32_t end = 0;
	GElf_Phdr ph;
	for (size_t i = 0; i < n; i++)	/* flash is 0 .. 0x7fffff in avr-ld's address space */
		if (gelf_getphdr(elf, (int)i, &ph) && ph.p_type == PT_LOAD && ph.p_filesz
				&& ph.p_paddr < 0x800000 && ph.p_paddr + ph.p_filesz > end)
			end = (uint32_t)(ph.p_paddr + ph.p_filesz);
	if (end <= fw->flashbase) {
		diag("cannot load firmware '%s': no code (.text) in the ELF", path);
		goto out;
	}
	uint8_t *flash = malloc(end - fw->flashbase);
	if (!flash) {
		diag("cannot load firmware '%s': out of memory", path);
		goto out;
	}
	memset(flash, 0xff, end - fw->flashbase);	/* erased flash */
	for (size_t i = 0; i < n; i++) {
		if (!gelf_getphdr(elf, (int)i, &ph) || ph.p_type != PT_LOAD || !ph.p_filesz
				|| ph.p_paddr >= 0x800000)
			continue;
		if (ph.p_paddr < fw->flashbase || pread(fd, flash + (ph.p_paddr - fw->flashbase),
				ph.p_filesz, (off_t)ph.p_offset) != (ssize_t)ph.p_filesz) {
			diag("cannot load firmware '%s': segment %zu at 0x%05lx unreadable", path, i,
				(unsigned long)ph.p_paddr);
			free(flash);
			goto out;
		}
	}
	free(fw->flash);
	fw->flash = flash;
	fw->flashsize = end - fw->flashbase;
	fw->datasize = 0;	/* simavr's end of code is then the end of the image */
	rc = 0;
out:
	if (elf)
		elf_end(elf);
	close(fd);
	return rc;
}

static avr_io_t *find_io(avr_t *avr, const char *kind, char name)
{
	for (avr_io_t *io = avr->io_port; io; io = io->next) {
		if (strcmp(io->kind, kind) != 0)
			continue;
		if (!strcmp(kind, "uart") && ((avr_uart_t *)io)->name != name)
			continue;
		return io;
	}
	return NULL;
}

static int open_tcp(int port, int *out_port)
{
	int s = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
	if (s < 0) {
		diag("socket: %s", strerror(errno));
		exit(EXIT_SETUP);
	}
	int one = 1;
	setsockopt(s, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
	struct sockaddr_in a = { .sin_family = AF_INET, .sin_port = htons((uint16_t)port) };
	a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	if (bind(s, (struct sockaddr *)&a, sizeof a) != 0) {
		diag("cannot listen on 127.0.0.1:%d: %s", port, strerror(errno));
		exit(EXIT_SETUP);
	}
	if (listen(s, 1) != 0) {
		diag("listen: %s", strerror(errno));
		exit(EXIT_SETUP);
	}
	socklen_t al = sizeof a;
	getsockname(s, (struct sockaddr *)&a, &al);
	*out_port = ntohs(a.sin_port);
	return s;
}

/* Waits for one client; returns its fd, or -1 on SIGINT/SIGTERM. */
static int accept_tcp(int ls)
{
	for (;;) {
		if (atomic_load(&g_stop_signal))
			return -1;
		struct pollfd p = { .fd = ls, .events = POLLIN };
		int r = poll(&p, 1, 200);
		if (r < 0 && errno != EINTR) {
			diag("poll: %s", strerror(errno));
			exit(EXIT_SETUP);
		}
		if (r <= 0)
			continue;
		int c = accept4(ls, NULL, NULL, SOCK_CLOEXEC);
		if (c < 0) {
			if (errno == EINTR || errno == ECONNABORTED || errno == EAGAIN)
				continue;
			diag("accept: %s", strerror(errno));
			exit(EXIT_SETUP);
		}
		int one = 1;
		setsockopt(c, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
		close(ls);
		return c;
	}
}

static int open_pty(char *name, size_t n)
{
	struct termios t;
	memset(&t, 0, sizeof t);
	cfmakeraw(&t);
	t.c_cflag |= CREAD | CLOCAL;
	cfsetispeed(&t, B115200);
	cfsetospeed(&t, B115200);
	int m, s;
	char buf[256];
	if (openpty(&m, &s, buf, &t, NULL) != 0) {
		diag("cannot create a pty: %s", strerror(errno));
		exit(EXIT_SETUP);
	}
	fcntl(m, F_SETFD, FD_CLOEXEC);
	/* packet mode before anyone can open the slave (see wait_pty_client) */
	int one = 1;
	if (ioctl(m, TIOCPKT, &one) != 0) {
		diag("ioctl(TIOCPKT): %s", strerror(errno));
		exit(EXIT_SETUP);
	}
	/* Close our slave fd: the master then reports POLLHUP until a client
	 * opens the slave, which is how we know one is there. */
	close(s);
	snprintf(name, n, "%s", buf);
	return m;
}

/* Sleeps ms milliseconds unless SIGINT/SIGTERM arrives; -1 if one did. */
static int sleep_ms_unless_signal(unsigned ms)
{
	uint64_t end = mono_ns() + (uint64_t)ms * 1000000u;
	for (;;) {
		if (atomic_load(&g_stop_signal))
			return -1;
		uint64_t now = mono_ns();
		if (now >= end)
			return 0;
		uint64_t left = end - now < 5000000u ? end - now : 5000000u;
		struct timespec ts = { 0, (long)left };
		nanosleep(&ts, NULL);
	}
}

/*
 * Waits for a pty client; 0 once it is there, -1 on SIGINT/SIGTERM.
 *
 * "There" means: the slave has been opened (the master stops reporting
 * POLLHUP), and the client has flushed its input queue, or max_ms passed.
 * pyserial's open() ends with tcflush(TCIFLUSH), which would throw away a
 * "ready" frame the firmware sent in the meantime; in packet mode (TIOCPKT)
 * the master sees that flush as TIOCPKT_FLUSHREAD, so the CPU starts right
 * after it.  A client that sends data first also counts as there.
 */
static int wait_pty_client(int m, unsigned max_ms)
{
	int zero = 0;
	uint64_t opened_at = 0;
	for (;;) {
		if (atomic_load(&g_stop_signal))
			return -1;
		struct pollfd p = { .fd = m, .events = POLLIN | POLLPRI };
		int r = poll(&p, 1, opened_at ? 1 : 0);
		if (r < 0 && errno != EINTR) {
			diag("poll: %s", strerror(errno));
			exit(EXIT_SETUP);
		}
		if (r < 0)
			continue;
		if (p.revents & POLLHUP) {
			opened_at = 0;	/* not (or no longer) open */
			struct timespec ts = { 0, 250000 };
			nanosleep(&ts, NULL);
			continue;
		}
		uint64_t now = mono_ns();
		if (!opened_at)
			opened_at = now;
		if (p.revents & (POLLIN | POLLPRI)) {
			uint8_t buf[4096];
			ssize_t n = read(m, buf, sizeof buf);
			if (n > 0 && buf[0] == TIOCPKT_DATA) {
				size_t len = (size_t)n - 1;
				memcpy(rx_ring, buf + 1, len);
				atomic_store(&rx_head, len);
				break;
			}
			if (n > 0 && (buf[0] & TIOCPKT_FLUSHREAD))
				break;
		}
		if (now - opened_at >= (uint64_t)max_ms * 1000000u)
			break;
	}
	ioctl(m, TIOCPKT, &zero);
	return 0;
}

/* For the trace, received bytes are logged when the firmware reads UDR0:
 * wrap the UART's read handler for that register.  (simavr aborts if a
 * second handler is registered, so the table entry is patched directly.) */
static avr_io_read_t udr_read_orig;
static void *udr_read_param;

static uint8_t udr_read_traced(avr_t *avr, avr_io_addr_t addr, void *param)
{
	(void)param;
	int had_byte = g_uart && avr_regbit_get(avr, g_uart->rxc.raised);
	uint8_t v = udr_read_orig(avr, addr, udr_read_param);
	if (had_byte) {
		avr_raise_irq(g_sig + SIG_RX, v);
		avr_raise_irq(g_sig + SIG_RX_STB, !g_sig[SIG_RX_STB].value);
	}
	return v;
}

static void setup_vcd(avr_t *avr)
{
	g_sig = avr_alloc_irq(&avr->irq_pool, 0, SIG_COUNT, sig_names);
	if (avr_vcd_init(avr, opt.vcd, &g_vcd, 1000) != 0) {
		diag("cannot write VCD file '%s'", opt.vcd);
		exit(EXIT_SETUP);
	}
	static const struct { int sig; int bits; const char *name; } s[] = {
		{ SIG_TX, 8, "uart0_tx" }, { SIG_TX_STB, 1, "uart0_tx_strobe" },
		{ SIG_RX, 8, "uart0_rx" }, { SIG_RX_STB, 1, "uart0_rx_strobe" },
		{ SIG_XOFF, 1, "uart0_xoff" }, { SIG_SLEEP, 1, "cpu_sleeping" },
	};
	for (size_t i = 0; i < sizeof s / sizeof s[0]; i++)
		avr_vcd_add_signal(&g_vcd, g_sig + s[i].sig, s[i].bits, s[i].name);
	/* output state of every I/O port the core has */
	for (const char *p = "ABCDEFGHJKL"; *p; p++) {
		avr_irq_t *irq = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(*p), IOPORT_IRQ_PIN_ALL);
		if (irq) {
			char name[16];
			snprintf(name, sizeof name, "port%c", *p);
			avr_vcd_add_signal(&g_vcd, irq, 8, name);
		}
	}
	if (g_uart) {
		avr_io_addr_t a = AVR_DATA_TO_IO(g_uart->r_udr);
		if (a < MAX_IOs && avr->io[a].r.c) {
			udr_read_orig = avr->io[a].r.c;
			udr_read_param = avr->io[a].r.param;
			avr->io[a].r.c = udr_read_traced;
		}
	}
	avr_vcd_start(&g_vcd);
	g_vcd_open = 1;
}

static void finish(int code)
{
	/* last words of the firmware, if the client takes them without waiting */
	if (g_fd >= 0 && out_len && !atomic_load(&g_peer_closed)) {
		ssize_t w = g_fd_is_socket ? send(g_fd, out_buf, out_len, MSG_NOSIGNAL)
			: write(g_fd, out_buf, out_len);
		if (w < (ssize_t)out_len)
			diag("could not pass on %zu byte(s) of firmware output", out_len - (w > 0 ? (size_t)w : 0));
	}
	if (opt.bootloader && g_avr && g_avr->flash)	/* NULL after simavr's cpu_Done */
		save_flash_image(g_avr);
	if (g_vcd_open) {
		avr_vcd_stop(&g_vcd);
		avr_vcd_close(&g_vcd);
	}
	fflush(stderr);
	exit(code);
}

/* Bootloader mode: flash image (if any), then the bootloader over it, and
 * the reset vector on the bootloader, as the BOOTRST fuse does. */
static int setup_boot_chip(avr_t *avr)
{
	if (opt.flash_image && load_flash_image(avr, opt.flash_image) != 0)
		return -1;
	uint32_t lo;
	if (load_ihex(opt.bootloader, avr->flash, avr->flashend + 1, &lo) != 0)
		return -1;
	if (lo == 0) {
		diag("'%s' starts at address 0: an application, not a bootloader", opt.bootloader);
		return -1;
	}
	g_boot_start = lo;
	avr->reset_pc = lo;
	avr->pc = lo;
	return 0;
}

/* The reader thread; signals stay with the main thread. */
static void start_reader(pthread_t *th)
{
	sigset_t all, old;
	sigfillset(&all);
	pthread_sigmask(SIG_BLOCK, &all, &old);
	if (pthread_create(th, NULL, opt.bootloader ? boot_reader_thread : reader_thread, NULL) != 0) {
		diag("cannot start the reader thread");
		finish(EXIT_SETUP);
	}
	pthread_sigmask(SIG_SETMASK, &old, NULL);
}

/* Bootloader mode: a client opened the pty.  Reset the chip into its
 * bootloader, keep the flash (and save it: the last client is done), and
 * drop input the previous client left behind. */
static void reset_chip(avr_t *avr)
{
	atomic_store(&g_reset_request, 0);
	size_t mark = atomic_load(&g_open_mark);
	save_flash_image(avr);
	avr_reset(avr);
	avr->pc = g_boot_start;
	g_uart_xoff = 0;
	out_len = 0;
	out_flush_now = 0;
	atomic_store(&rx_tail, mark);
}

/* Bootloader mode: opens of the pty slave, seen from the first one on. */
static void watch_pty_opens(const char *ptyname)
{
	g_inotify = inotify_init1(IN_CLOEXEC);
	if (g_inotify < 0 || inotify_add_watch(g_inotify, ptyname, IN_OPEN) < 0) {
		diag("cannot watch %s for opens (inotify): %s", ptyname, strerror(errno));
		exit(EXIT_SETUP);
	}
	int zero = 0;
	ioctl(g_fd, TIOCPKT, &zero);	/* no start-up handshake: the open is the reset */
}

/* ------------------------------------------------------------------------ */

int main(int argc, char **argv)
{
	/* stdout carries exactly one line: keep a private handle on it and
	 * point fd 1 at stderr, so that any printf() inside simavr lands there */
	int out_fd = dup(STDOUT_FILENO);
	FILE *url_out = out_fd >= 0 ? fdopen(out_fd, "w") : NULL;
	g_stdout = url_out;
	if (!url_out) {
		diag("cannot duplicate stdout: %s", strerror(errno));
		return EXIT_SETUP;
	}
	fcntl(out_fd, F_SETFD, FD_CLOEXEC);
	dup2(STDERR_FILENO, STDOUT_FILENO);

	parse_args(argc, argv);
	avr_global_logger_set(sim_logger);
	signal(SIGPIPE, SIG_IGN);

	struct sigaction sa;
	memset(&sa, 0, sizeof sa);
	sa.sa_handler = on_signal;
	sigemptyset(&sa.sa_mask);
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);

	/* firmware + core */
	elf_firmware_t fw;
	memset(&fw, 0, sizeof fw);
	if (opt.elf) {
		check_elf_file(opt.elf);
		if (elf_read_firmware(opt.elf, &fw) != 0) {
			diag("cannot load firmware '%s': simavr could not read the ELF", opt.elf);
			return EXIT_SETUP;
		}
		if (load_flash_segments(opt.elf, &fw) != 0)
			return EXIT_SETUP;
		if (fw.mmcu[0] && strcmp(fw.mmcu, opt.mcu) != 0)
			diag("warning: '%s' says it is for %s, simulating %s", opt.elf, fw.mmcu, opt.mcu);
	}

	avr_t *avr = avr_make_mcu_by_name(opt.mcu);
	if (!avr) {
		diag("unknown MCU '%s'", opt.mcu);
		return EXIT_USAGE;
	}
	g_avr = avr;
	avr_init(avr);
	avr->log = (uint8_t)opt.log_level;
	if (opt.bootloader) {
		if (setup_boot_chip(avr) != 0)
			return EXIT_SETUP;
	} else {
		if ((uint64_t)fw.flashbase + fw.flashsize > (uint64_t)avr->flashend + 1) {
			diag("cannot load firmware '%s': %u bytes of code do not fit the %s's %u bytes of flash",
				opt.elf, (unsigned)fw.flashsize, opt.mcu, (unsigned)avr->flashend + 1);
			return EXIT_SETUP;
		}
		fw.frequency = opt.freq;
		avr->frequency = opt.freq;
		avr_load_firmware(avr, &fw);
	}
	avr->frequency = opt.freq;

	/* UART0: no usleep() on RX polls, no stdio line echo; our own pump */
	uint32_t flags = 0;
	if (avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags) != 0) {
		diag("MCU '%s' has no UART0", opt.mcu);
		return EXIT_USAGE;
	}
	flags &= ~(uint32_t)(AVR_UART_FLAG_POLL_SLEEP | AVR_UART_FLAG_STDIO);
	avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
	g_uart = (avr_uart_t *)find_io(avr, "uart", '0');
	g_wdt = (avr_watchdog_t *)find_io(avr, "watchdog", 0);
	g_uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
	avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
		on_uart_output, NULL);
	avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON),
		on_uart_xon, NULL);
	avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
		on_uart_xoff, NULL);

	if (opt.vcd)
		setup_vcd(avr);

	if (opt.gdb_port >= 0) {
		avr->gdb_port = opt.gdb_port;
		if (avr_gdb_init(avr) != 0) {
			diag("cannot start the gdb server on port %d", opt.gdb_port);
			return EXIT_SETUP;
		}
		avr->state = cpu_Stopped;	/* until gdb says continue */
	}
	avr->sleep = opt.realtime ? sleep_realtime : sleep_free;
	if (opt.realtime)
		prctl(PR_SET_TIMERSLACK, 1000UL);	/* 1 us instead of 50 us */

	/* transport */
	int ls = -1, port = 0;
	char ptyname[256];
	if (opt.transport == TR_TCP) {
		ls = open_tcp(opt.tcp_port, &port);
		fprintf(url_out, PROG ": listening url=socket://127.0.0.1:%d\n", port);
	} else {
		g_fd = open_pty(ptyname, sizeof ptyname);
		if (opt.bootloader)
			watch_pty_opens(ptyname);
		fprintf(url_out, PROG ": listening url=%s\n", ptyname);
	}
	fflush(url_out);
	if (opt.gdb_port >= 0)
		diag("gdb server on port %d: the CPU waits for gdb ('target remote :%d', then 'continue')",
			opt.gdb_port, opt.gdb_port);

	if (opt.transport == TR_TCP) {
		g_fd = accept_tcp(ls);
		g_fd_is_socket = 1;
		/* pyserial's socket:// open() ends by reading and discarding
		 * whatever has arrived (reset_input_buffer): give it time */
		if (g_fd >= 0 && sleep_ms_unless_signal(opt.start_delay_ms) != 0)
			g_fd = -1;
	} else if (!opt.bootloader && wait_pty_client(g_fd, opt.start_delay_ms) != 0) {
		g_fd = -1;
	}
	if (g_fd < 0) {
		diag("stopped by signal %d before a client connected", atomic_load(&g_stop_signal));
		finish(EXIT_CLEAN);
	}

	/* non-blocking: a blocked write must not outlive SIGTERM */
	fcntl(g_fd, F_SETFL, fcntl(g_fd, F_GETFL) | O_NONBLOCK);

	pthread_condattr_t ca;
	pthread_condattr_init(&ca);
	pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
	pthread_cond_init(&rt_cond, &ca);
	pthread_t th;
	start_reader(&th);

	/* sim loop */
	const avr_cycle_count_t period = avr->frequency / 10000 ? avr->frequency / 10000 : 1; /* 100 us */
	const avr_cycle_count_t limit = opt.cycles_limit ? opt.cycles_limit : UINT64_MAX;
	avr_cycle_count_t next_check = avr->cycle + period < limit ? avr->cycle + period : limit;
	int rt_rebase = 0;
	/* avr->codeend: end of the flash image as loaded from the ELF */
	const avr_flashaddr_t code_end = avr->codeend ? avr->codeend : avr->flashend + 1;
	if (opt.log_level >= LOG_TRACE)
		diag("code ends at 0x%05x, flash ends at 0x%05x", (unsigned)code_end, (unsigned)avr->flashend);
	int last_state = avr->state;
	rt_base_ns = mono_ns();
	rt_base_cycle = avr->cycle;

	for (;;) {
		avr->run(avr);

		if (__builtin_expect(avr->state >= cpu_Done || avr->pc >= code_end
				|| atomic_load_explicit(&g_attention, memory_order_relaxed), 0)) {
			/* clear first: the flags below are sticky, a new event re-raises it */
			atomic_store(&g_attention, 0);
			if (avr->state == cpu_Done) {
				diag("firmware halted: SLEEP with interrupts disabled at PC=0x%05x "
					"after %llu cycles (simavr cpu_Done)",
					(unsigned)avr->pc, (unsigned long long)avr->cycle);
				finish(EXIT_HALT);
			}
			if (avr->state == cpu_Crashed) {
				diag("firmware crashed at PC=0x%05x after %llu cycles (simavr cpu_Crashed)%s%s",
					(unsigned)avr->pc, (unsigned long long)avr->cycle,
					g_fault ? ": " : "", g_fault ? g_fault_msg : "");
				finish(EXIT_CRASH);
			}
			if (avr->pc >= code_end && !g_fault) {
				/* simavr runs erased flash (0xffff) as a valid opcode up to
				 * the end of flash; catch the wild jump where it lands */
				g_fault = 1;
				snprintf(g_fault_msg, sizeof g_fault_msg,
					"executing outside the firmware's code (PC=0x%05x, code ends at 0x%05x)",
					(unsigned)avr->pc, (unsigned)code_end);
			}
			if (atomic_load(&g_reset_request))
				reset_chip(avr);
			if (atomic_exchange(&g_client_left, 0))
				save_flash_image(avr);
			int sig = atomic_load(&g_stop_signal);
			if (sig) {
				diag("stopped by signal %d after %llu cycles", sig, (unsigned long long)avr->cycle);
				finish(EXIT_CLEAN);
			}
			if (g_fault == 1) {
				if (opt.gdb_port >= 0) {
					/* leave it to gdb: stop the core, keep serving */
					diag("firmware fault, stopped for gdb: %s", g_fault_msg);
					g_fault = 2;
					avr_sadly_crashed(avr, 4 /* SIGILL */);
				} else {
					diag("firmware crashed at PC=0x%05x after %llu cycles: %s",
						(unsigned)avr->pc, (unsigned long long)avr->cycle, g_fault_msg);
					finish(EXIT_CRASH);
				}
			}
			if (atomic_load(&g_peer_closed)) {
				diag("client disconnected after %llu cycles", (unsigned long long)avr->cycle);
				finish(EXIT_CLEAN);
			}
		}

		if (__builtin_expect(opt.realtime, 0)) {
			/* the wall clock restarts when gdb lets a stopped CPU go */
			if (avr->state == cpu_Stopped) {
				rt_rebase = 1;
			} else if (rt_rebase) {
				rt_rebase = 0;
				rt_base_ns = mono_ns();
				rt_base_cycle = avr->cycle;
			}
		}

		if (!g_uart_xoff && rx_pending())
			feed_uart();

		if (out_len && (out_flush_now || avr->cycle - out_last_cycle > 2 * (g_uart ? g_uart->cycles_per_byte : 512)))
			out_flush();

		if (g_sig && avr->state != last_state) {
			last_state = avr->state;
			avr_raise_irq(g_sig + SIG_SLEEP, last_state == cpu_Sleeping);
		}

		if (avr->cycle >= next_check) {
			if (avr->cycle >= limit) {
				diag("cycle limit reached (%llu cycles)", (unsigned long long)avr->cycle);
				finish(EXIT_CLEAN);
			}
			if (halted_in_dead_loop(avr)) {
				diag("firmware halted: endless jump-to-self with interrupts disabled at PC=0x%05x "
					"after %llu cycles (returned from main, or called exit/abort?)",
					(unsigned)avr->pc, (unsigned long long)avr->cycle);
				finish(EXIT_HALT);
			}
			if (opt.realtime && avr->state != cpu_Stopped)
				rt_pace(avr);
			else if (opt.bootloader && avr->state != cpu_Stopped)
				boot_pace(avr);
			next_check = avr->cycle + period < limit ? avr->cycle + period : limit;
		}
	}
}
