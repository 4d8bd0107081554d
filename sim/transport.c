/* The client's end: a loopback TCP socket or a pseudo-terminal, and the wait
 * for a client that is ready to read (see sim/README.md, "Start-up"). */
#include "bridge.h"

#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <arpa/inet.h>
#include <poll.h>
#include <pty.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

int open_tcp(int port, int *out_port)
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

/* A Unix-domain stream socket at path (a socket file left there by an earlier run is
 * replaced; any other file is an error). */
int open_unix(const char *path)
{
	struct sockaddr_un a = { .sun_family = AF_UNIX };
	if (strlen(path) >= sizeof a.sun_path) {
		diag("--unix: the path '%s' is longer than a socket's %zu bytes", path, sizeof a.sun_path - 1);
		exit(EXIT_USAGE);
	}
	strcpy(a.sun_path, path);
	struct stat st;
	if (lstat(path, &st) == 0) {
		if (!S_ISSOCK(st.st_mode)) {
			diag("--unix: '%s' exists and is not a socket: give a path to a new file", path);
			exit(EXIT_SETUP);
		}
		unlink(path);
	}
	int s = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
	if (s < 0 || bind(s, (struct sockaddr *)&a, sizeof a) != 0 || listen(s, 1) != 0) {
		diag("cannot listen on the socket '%s': %s", path, strerror(errno));
		exit(EXIT_SETUP);
	}
	return s;
}

/* Waits for one client; returns its fd, or -1 on SIGINT/SIGTERM. */
int accept_client(int ls)
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
		if (opt.transport == TR_TCP)
			setsockopt(c, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
		close(ls);
		return c;
	}
}

int open_pty(char *name, size_t n)
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
int sleep_ms_unless_signal(unsigned ms)
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
int wait_pty_client(int m, unsigned max_ms)
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
