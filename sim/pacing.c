/* Simulated time against the wall clock: free-running sleeps, --realtime
 * pacing, and the waits that new input ends early. */
#include "bridge.h"

#include <errno.h>
#include <poll.h>
#include <sched.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

uint64_t mono_ns(void)
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

/* realtime mode: the sim loop may wait for wall-clock time; new input wakes it */
static pthread_mutex_t rt_lock = PTHREAD_MUTEX_INITIALIZER;
pthread_cond_t rt_cond;

void wake_paced(void)
{
	if (opt.realtime || opt.bootloader) {	/* the sim loop may be waiting */
		pthread_mutex_lock(&rt_lock);
		pthread_cond_signal(&rt_cond);
		pthread_mutex_unlock(&rt_lock);
	}
}


uint64_t rt_base_ns;		/* wall clock at rt_base_cycle */
avr_cycle_count_t rt_base_cycle;

static void timing_caught_up(void);
static void timing_steal(uint64_t now);

/* The waits below (on the sim thread) last until the monotonic clock reaches deadline,
 * or input for the UART arrives, or something needs attention.  This one, when the sim
 * thread reads the client itself (g_sim_reads), waits on the client's fd. */
static void poll_wait(uint64_t deadline)
{
	while (!input_wakes() && !atomic_load(&g_attention)) {
		uint64_t now = mono_ns();
		if (now >= deadline)
			return;
		struct timespec ts = { (time_t)((deadline - now) / 1000000000u),
			(long)((deadline - now) % 1000000000u) };
		int room = atomic_load(&rx_head) - atomic_load(&rx_tail) < RX_RING_SIZE;
		struct pollfd p = { .fd = g_fd, .events = room ? POLLIN : 0 };
		if (ppoll(&p, 1, &ts, NULL) > 0 && room)
			sim_read_input();
	}
}

static void cond_wait(uint64_t deadline)
{
	struct timespec ts = { (time_t)(deadline / 1000000000u), (long)(deadline % 1000000000u) };
	pthread_mutex_lock(&rt_lock);
	while (!input_wakes() && !atomic_load(&g_attention)) {
		if (pthread_cond_timedwait(&rt_cond, &rt_lock, &ts) == ETIMEDOUT)
			break;
	}
	pthread_mutex_unlock(&rt_lock);
}

static void rt_wait(uint64_t deadline)
{
	if (g_timing)
		timing_caught_up();
	if (g_sim_reads)
		poll_wait(deadline);
	else
		cond_wait(deadline);	/* the reader thread signals rt_cond */
	if (g_timing) {
		uint64_t now = mono_ns();
		if (now > deadline + 200000)
			fprintf(g_timing, "overslept %llu %llu\n", (unsigned long long)deadline,
				(unsigned long long)now);
	}
}

/* Under a real-time scheduling policy, inherited from the host that started us, the
 * bridge's threads (this one and any started later) take one priority above
 * the host's: simulated time, like a chip's clock, must not wait while the host's own
 * threads keep both cores busy at the same priority for a whole round-robin slice. */
void above_the_host(void)
{
	int policy = sched_getscheduler(0);
	struct sched_param sp;
	if ((policy != SCHED_RR && policy != SCHED_FIFO) || sched_getparam(0, &sp) != 0)
		return;
	if (sp.sched_priority < sched_get_priority_max(policy)) {
		sp.sched_priority++;
		if (sched_setscheduler(0, policy, &sp) != 0)
			diag("cannot take real-time priority %d above the host's: %s",
				sp.sched_priority, strerror(errno));
	}
}

/* Free-running: a sleeping CPU just skips ahead to the next timer. */
void sleep_free(avr_t *avr, avr_cycle_count_t howlong)
{
	(void)avr; (void)howlong;
}

/* Realtime: wait for the wall clock to reach the end of the sleep; if input
 * arrives first, only advance simulated time up to "now" (the caller adds
 * howlong + 1 to avr->cycle after we return, so we take the rest back). */
void sleep_realtime(avr_t *avr, avr_cycle_count_t howlong)
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
void rt_pace(avr_t *avr)
{
	if (g_sim_reads)
		sim_read_input();
	uint64_t sim = sim_ns(avr), now = mono_ns();
	if (g_timing)
		timing_steal(now);
	if (sim > now)
		rt_wait(sim);
	else if (g_timing)
		timing_behind(now - sim);
}

/* --timing: where an exchange's wall time went (see sim/README.md, "Timing log") */
FILE *g_timing;
atomic_uint_fast64_t g_read_ns;	/* when the reader thread last read client bytes */
static uint64_t behind_from, behind_most;

uint64_t sim_ns(avr_t *avr)
{
	return rt_base_ns + cycles_to_ns(avr->cycle - rt_base_cycle, avr->frequency);
}

void timing_in(size_t n)
{
	fprintf(g_timing, "in %llu %llu %llu %llu %zu\n",
		(unsigned long long)atomic_load(&g_read_ns), (unsigned long long)mono_ns(),
		(unsigned long long)g_avr->cycle, (unsigned long long)sim_ns(g_avr), n);
}

void timing_out(size_t n, uint64_t start, uint64_t end)
{
	fprintf(g_timing, "out %llu %llu %llu %llu %zu\n", (unsigned long long)start,
		(unsigned long long)end, (unsigned long long)g_avr->cycle,
		(unsigned long long)sim_ns(g_avr), n);
}

/* A stretch in which simulated time was behind the wall clock at every pacing check;
 * logged when it ends, if it ever was more than 200 us behind. */
void timing_behind(uint64_t by)
{
	uint64_t now = mono_ns();
	if (!behind_from)
		behind_from = now;
	if (by > behind_most)
		behind_most = by;
}

/* CPU time the hypervisor gave to others while this machine's CPUs wanted it (steal,
 * per CPU, from /proc/stat): read every 10 ms, logged when it grew. A CPU taken away
 * stops whatever threads its run queue holds, simulated time's and the host's alike. */
#define STEAL_CPUS 64
static void timing_steal(uint64_t now)
{
	static uint64_t next_ns;
	static unsigned long long last[STEAL_CPUS];
	static int have_last;
	if (now < next_ns)
		return;
	next_ns = now + 10000000u;
	FILE *f = fopen("/proc/stat", "r");
	if (!f)
		return;
	unsigned long long cur[STEAL_CPUS] = { 0 };
	int n = 0;
	char line[512];
	while (n < STEAL_CPUS && fgets(line, sizeof line, f)) {	/* cpuN lines; not "cpu ", their sum */
		unsigned long long v[8];
		int cpu;
		if (line[3] != ' ' && sscanf(line, "cpu%d %llu %llu %llu %llu %llu %llu %llu %llu", &cpu, &v[0], &v[1],
				&v[2], &v[3], &v[4], &v[5], &v[6], &v[7]) == 9)
			cur[n++] = v[7];
	}
	fclose(f);
	long tick = sysconf(_SC_CLK_TCK);
	int grew = 0;
	for (int i = 0; i < n; i++)
		grew |= have_last && cur[i] > last[i];
	if (grew) {
		fprintf(g_timing, "steal %llu", (unsigned long long)now);
		for (int i = 0; i < n; i++)
			fprintf(g_timing, " %llu", (cur[i] - last[i]) * 1000ull / (unsigned long long)tick);
		fputc('\n', g_timing);
	}
	memcpy(last, cur, sizeof last);
	have_last = 1;
}

static void timing_caught_up(void)
{
	if (behind_from && behind_most > 200000)
		fprintf(g_timing, "behind %llu %llu %llu\n", (unsigned long long)behind_from,
			(unsigned long long)mono_ns(), (unsigned long long)behind_most);
	behind_from = behind_most = 0;
}
