/* What the parts of the simavr bridge share: options, exit codes, the flags
 * that stop the sim loop, and each part's entry points.  One part a file:
 *   vehil_simavr.c  main, the sim loop, diagnostics, halting detection
 *   options.c       the command line
 *   elf_load.c      the firmware ELF
 *   transport.c     the client's pty or TCP socket, and the start-up handshake
 *   uart_pump.c     client <-> UART0 (reader thread, ring, output buffer)
 *   uart_timing.c   UART0 timed as the chip times it (--uart chip)
 *   pacing.c        sleeping, --realtime, wall-clock waits
 *   bootloader.c    --bootloader mode
 *   vcd_trace.c     --vcd
 *   profiler.c      --profile
 */
#ifndef VEHIL_SIMAVR_BRIDGE_H
#define VEHIL_SIMAVR_BRIDGE_H

#define _GNU_SOURCE
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <sys/types.h>

#include <sim_avr.h>
#include <sim_elf.h>
#include <sim_vcd_file.h>
#include <avr_uart.h>
#include <avr_watchdog.h>

#define PROG "vehil-simavr"

enum {
	EXIT_CLEAN = 0,
	EXIT_SETUP = 1,
	EXIT_USAGE = 2,
	EXIT_CRASH = 3,
	EXIT_HALT = 4,
};

enum transport { TR_TCP, TR_UNIX, TR_PTY };
/* Default transport (see sim/README.md): as fast as TCP, loss-free, and the
 * CPU can start exactly when pyserial's open() is done (no fixed delay). */
#define DEFAULT_TRANSPORT TR_PTY


/* options.c */
struct options {
	enum transport transport;
	int tcp_port;
	const char *unix_path;	/* --unix PATH */
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
	const char *profile;		/* --profile FILE; NULL: off */
	const char *profile_map;	/* the functions' address ranges */
	const char *profile_window;	/* ranges that open a window; NULL: the run */
	const char *profile_window_end;	/* ranges that close it; NULL: leaving those */
	const char *timing;		/* --timing FILE; NULL: off */
	int simavr_uart;		/* --uart simavr: simavr's own UART0 timing */
};
extern struct options opt;
void usage(FILE *f);
void parse_args(int argc, char **argv);

/* vehil_simavr.c */
void diag(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
extern atomic_int g_attention;
extern atomic_int g_stop_signal;
extern atomic_int g_peer_closed;
extern FILE *g_stdout;
void finish(int code) __attribute__((noreturn));

/* elf_load.c */
void check_elf_file(const char *path);
int load_flash_segments(const char *path, elf_firmware_t *fw);

/* transport.c */
int open_tcp(int port, int *out_port);
int open_unix(const char *path);
int accept_client(int ls);
int open_pty(char *name, size_t n);
int sleep_ms_unless_signal(unsigned ms);
int wait_pty_client(int m, unsigned max_ms);

/* uart_pump.c */
#define RX_RING_SIZE (1u << 16)
extern uint8_t rx_ring[RX_RING_SIZE];
extern atomic_size_t rx_head;
extern atomic_size_t rx_tail;
extern int g_fd;
extern int g_fd_is_socket;
extern avr_t *g_avr;
extern avr_uart_t *g_uart;
extern avr_watchdog_t *g_wdt;
extern avr_irq_t *g_uart_in;
extern int g_uart_xoff;
extern uint8_t out_buf[1u << 16];
extern size_t out_len;
extern int out_flush_now;
extern avr_cycle_count_t out_last_cycle;
extern avr_cycle_count_t in_last_cycle;
ssize_t ring_read(void);
void *reader_thread(void *arg);
extern int g_sim_reads;
void sim_read_input(void);
void out_flush(void);
void on_uart_output(avr_irq_t *irq, uint32_t value, void *param);
void on_uart_xon(avr_irq_t *irq, uint32_t value, void *param);
void on_uart_xoff(avr_irq_t *irq, uint32_t value, void *param);
void feed_uart(void);
int rx_take(void);
void rx_started(void);
int rx_pending(void);
int input_wakes(void);

/* pacing.c */
extern pthread_cond_t rt_cond;
extern uint64_t rt_base_ns;
extern avr_cycle_count_t rt_base_cycle;
uint64_t mono_ns(void);
void wake_paced(void);
void sleep_free(avr_t *avr, avr_cycle_count_t howlong);
void sleep_realtime(avr_t *avr, avr_cycle_count_t howlong);
void rt_pace(avr_t *avr);
void above_the_host(void);
extern FILE *g_timing;
extern atomic_uint_fast64_t g_read_ns;
uint64_t sim_ns(avr_t *avr);
void timing_in(size_t n);
void timing_out(size_t n, uint64_t start, uint64_t end);
void timing_behind(uint64_t by);

/* bootloader.c */
extern atomic_int g_reset_request;
extern atomic_int g_attached;
extern atomic_int g_client_left;
void *boot_reader_thread(void *arg);
void save_flash_image(avr_t *avr);
void boot_pace(avr_t *avr);
int setup_boot_chip(avr_t *avr);
void reset_chip(avr_t *avr);
void watch_pty_opens(const char *ptyname);

/* uart_timing.c */
extern int g_rx_busy;
int uart_timing_setup(avr_t *avr, avr_uart_t *uart);
void uart_timing_rx_start(avr_t *avr);

/* vcd_trace.c */
enum { SIG_TX, SIG_TX_STB, SIG_RX, SIG_RX_STB, SIG_XOFF, SIG_SLEEP, SIG_COUNT };
extern avr_irq_t *g_sig;
extern avr_vcd_t g_vcd;
extern int g_vcd_open;
void setup_vcd(avr_t *avr);

/* profiler.c */
extern int g_profiling;
extern atomic_int g_profile_cut;	/* SIGUSR1 */
int profiler_setup(avr_t *avr);
void profiler_step(avr_t *avr, avr_flashaddr_t pc0, avr_cycle_count_t c0, uint8_t rp0, int state0);
void profiler_cut(void);
void profiler_finish(void);

#endif
