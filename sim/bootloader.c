/* Bootloader mode: a chip that is programmed through its bootloader (see
 * sim/README.md, "Bootloader mode"). */
#include "bridge.h"

#include <errno.h>
#include <limits.h>
#include <poll.h>
#include <stdlib.h>
#include <string.h>
#include <sys/inotify.h>
#include <sys/ioctl.h>
#include <unistd.h>

/* Bootloader mode: clients come and go, and each open of the pty resets the
 * chip, as opening a Mega's port does (DTR).  inotify reports the opens (the
 * master sees none, and misses a close that a quick reopen follows); the
 * master's POLLHUP says nobody has the port open, and output is dropped. */
static int g_inotify = -1;
atomic_int g_reset_request;
static atomic_size_t g_open_mark;	/* rx_head when the port was opened */
atomic_int g_attached;		/* someone has the pty open */
atomic_int g_client_left;

void *boot_reader_thread(void *arg)
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
void save_flash_image(avr_t *avr)
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

void boot_pace(avr_t *avr)
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

/* Bootloader mode: flash image (if any), then the bootloader over it, and
 * the reset vector on the bootloader, as the BOOTRST fuse does. */
int setup_boot_chip(avr_t *avr)
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

/* Bootloader mode: a client opened the pty.  Reset the chip into its
 * bootloader, keep the flash (and save it: the last client is done), and
 * drop input the previous client left behind. */
void reset_chip(avr_t *avr)
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
void watch_pty_opens(const char *ptyname)
{
	g_inotify = inotify_init1(IN_CLOEXEC);
	if (g_inotify < 0 || inotify_add_watch(g_inotify, ptyname, IN_OPEN) < 0) {
		diag("cannot watch %s for opens (inotify): %s", ptyname, strerror(errno));
		exit(EXIT_SETUP);
	}
	int zero = 0;
	ioctl(g_fd, TIOCPKT, &zero);	/* no start-up handshake: the open is the reset */
}
