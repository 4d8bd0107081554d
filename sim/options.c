/* The command line. */
#include "bridge.h"

#include <errno.h>
#include <getopt.h>
#include <stdlib.h>
#include <string.h>

struct options opt = {
	.transport = DEFAULT_TRANSPORT,
	.tcp_port = 0,
	.mcu = "atmega2560",
	.freq = 16000000,
	.gdb_port = -1,
	.log_level = LOG_ERROR,
	.start_delay_ms = 100,
};

void usage(FILE *f)
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
"  " PROG ": listening url=unix://PATH                (--unix)\n"
"The CPU starts only once the client is connected (see --start-delay).\n"
"\n"
"options:\n"
"  --pty              serve UART0 on a new pseudo-terminal (the default)\n"
"  --tcp PORT         serve UART0 on 127.0.0.1:PORT, one client (0 = pick a\n"
"                     free port)\n"
"  --unix PATH        serve UART0 on a Unix-domain socket at PATH, one client\n"
"                     (as --tcp, without the TCP stack: ~11 us less a round trip)\n"
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
"  --profile FILE     count cycles per function and call stack into FILE\n"
"                     (needs --profile-map; see sim/README.md, Profiling)\n"
"  --profile-map FILE the functions: one 'START END' a line, hex byte\n"
"                     addresses, END exclusive; the line index is the id\n"
"  --profile-window R count only from the PC entering ranges R\n"
"                     (LO-HI[,LO-HI...], hex) until it leaves them in that\n"
"                     frame; default: the whole run, cut by SIGUSR1\n"
"  --profile-window-end R  with --profile-window: close the window when its\n"
"                     outermost frame reaches ranges R instead\n"
"  --timing FILE      with --realtime: log each batch of client bytes fed to\n"
"                     the UART and each write to the client, with the wall\n"
"                     clock and simulated time (see sim/README.md)\n"
"  --uart chip|simavr UART0's timing: the ATmega2560's (the default: 10 bits an\n"
"                     8N1 frame, double-buffered TX) or simavr's own (11 bits,\n"
"                     UDRE0 back only when the byte is out; see sim/README.md)\n"
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

void parse_args(int argc, char **argv)
{
	enum { O_TCP = 256, O_UNIX, O_PTY, O_MCU, O_FREQ, O_RT, O_LIMIT, O_VCD, O_GDB, O_DELAY, O_BOOT, O_IMAGE,
		O_PROFILE, O_PROFILE_MAP, O_PROFILE_WINDOW, O_PROFILE_END, O_TIMING, O_UART };
	static const struct option lo[] = {
		{ "tcp", required_argument, NULL, O_TCP },
		{ "unix", required_argument, NULL, O_UNIX },
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
		{ "profile", required_argument, NULL, O_PROFILE },
		{ "profile-map", required_argument, NULL, O_PROFILE_MAP },
		{ "profile-window", required_argument, NULL, O_PROFILE_WINDOW },
		{ "profile-window-end", required_argument, NULL, O_PROFILE_END },
		{ "timing", required_argument, NULL, O_TIMING },
		{ "uart", required_argument, NULL, O_UART },
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
		case O_UNIX:
			opt.transport = TR_UNIX;
			opt.unix_path = optarg;
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
		case O_PROFILE:
			opt.profile = optarg;
			break;
		case O_PROFILE_MAP:
			opt.profile_map = optarg;
			break;
		case O_PROFILE_WINDOW:
			opt.profile_window = optarg;
			break;
		case O_PROFILE_END:
			opt.profile_window_end = optarg;
			break;
		case O_TIMING:
			opt.timing = optarg;
			break;
		case O_UART:
			if (strcmp(optarg, "chip") && strcmp(optarg, "simavr")) {
				diag("--uart: '%s' is neither 'chip' nor 'simavr'", optarg);
				exit(EXIT_USAGE);
			}
			opt.simavr_uart = !strcmp(optarg, "simavr");
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
		diag("give only one of --tcp, --unix and --pty");
		exit(EXIT_USAGE);
	}
	if (opt.flash_image && !opt.bootloader) {
		diag("--flash-image needs --bootloader");
		exit(EXIT_USAGE);
	}
	if (opt.bootloader && opt.transport != TR_PTY) {
		/* a new client must reset the chip: only the pty shows who opens it */
		diag("--bootloader serves a pty only, not --tcp or --unix");
		exit(EXIT_USAGE);
	}
	if (opt.profile && (!opt.profile_map || opt.bootloader || opt.gdb_port >= 0)) {
		diag(!opt.profile_map ? "--profile needs --profile-map (the functions' addresses)"
			: "--profile runs the ELF alone: not with --bootloader or --gdb");
		exit(EXIT_USAGE);
	}
	if (!opt.profile && (opt.profile_map || opt.profile_window)) {
		diag("--profile-map and --profile-window need --profile FILE");
		exit(EXIT_USAGE);
	}
	if (opt.profile_window_end && !opt.profile_window) {
		diag("--profile-window-end says where a window closes: it needs --profile-window");
		exit(EXIT_USAGE);
	}
	if (opt.timing && !opt.realtime) {
		diag("--timing compares simulated time with the wall clock: it needs --realtime");
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
