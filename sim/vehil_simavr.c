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
#include "bridge.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <sim_gdb.h>

/* ------------------------------------------------------------------------ */
/* diagnostics */

void diag(const char *fmt, ...)
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
atomic_int g_attention;
atomic_int g_stop_signal;	/* signal number, 0 if none */
atomic_int g_peer_closed;
static int g_fault;			/* set by the logger, sim thread only */
static char g_fault_msg[256];

static void on_signal(int sig)
{
	if (sig == SIGUSR1) {
		atomic_store(&g_profile_cut, 1);
		atomic_store(&g_attention, 1);
		return;
	}
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

FILE *g_stdout;		/* the real stdout; fd 1 points at stderr */

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

void finish(int code)
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
	profiler_finish();
	if (g_timing)
		fclose(g_timing);
	if (opt.unix_path)
		unlink(opt.unix_path);
	if (g_vcd_open) {
		avr_vcd_stop(&g_vcd);
		avr_vcd_close(&g_vcd);
	}
	fflush(stderr);
	exit(code);
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
	sigaction(SIGUSR1, &sa, NULL);

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
	if (!opt.simavr_uart && uart_timing_setup(avr, g_uart) != 0)
		return EXIT_SETUP;
	g_uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
	avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
		on_uart_output, NULL);
	avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON),
		on_uart_xon, NULL);
	avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
		on_uart_xoff, NULL);

	if (opt.vcd)
		setup_vcd(avr);
	if (opt.profile && profiler_setup(avr) != 0)
		return EXIT_SETUP;
	if (opt.timing && !(g_timing = fopen(opt.timing, "w"))) {
		diag("cannot write the timing log '%s': %s", opt.timing, strerror(errno));
		return EXIT_SETUP;
	}

	if (opt.gdb_port >= 0) {
		avr->gdb_port = opt.gdb_port;
		if (avr_gdb_init(avr) != 0) {
			diag("cannot start the gdb server on port %d", opt.gdb_port);
			return EXIT_SETUP;
		}
		avr->state = cpu_Stopped;	/* until gdb says continue */
	}
	avr->sleep = opt.realtime ? sleep_realtime : sleep_free;
	if (opt.realtime) {
		prctl(PR_SET_TIMERSLACK, 1000UL);	/* 1 us instead of 50 us */
		above_the_host();
	}

	/* transport */
	int ls = -1, port = 0;
	char ptyname[256];
	if (opt.transport == TR_TCP) {
		ls = open_tcp(opt.tcp_port, &port);
		fprintf(url_out, PROG ": listening url=socket://127.0.0.1:%d\n", port);
	} else if (opt.transport == TR_UNIX) {
		ls = open_unix(opt.unix_path);
		fprintf(url_out, PROG ": listening url=unix://%s\n", opt.unix_path);
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

	if (opt.transport != TR_PTY) {
		g_fd = accept_client(ls);
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
	g_sim_reads = opt.realtime && !opt.bootloader;
	if (!g_sim_reads)
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
		if (__builtin_expect(g_profiling, 0)) {
			avr_flashaddr_t pc = avr->pc;
			avr_cycle_count_t c = avr->cycle;
			uint8_t rp = avr->interrupts.running_ptr;
			int state = avr->state;
			avr->run(avr);
			profiler_step(avr, pc, c, rp, state);
		} else {
			avr->run(avr);
		}

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
			if (atomic_exchange(&g_profile_cut, 0))
				profiler_cut();
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

		if (!g_uart_xoff && !g_rx_busy && rx_pending())	/* checked every instruction */
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
