/* Simulated time against the wall clock: free-running sleeps, --realtime
 * pacing, and the waits that new input ends early. */
#include "bridge.h"

#include <errno.h>
#include <time.h>

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
	uint64_t sim = rt_base_ns + cycles_to_ns(avr->cycle - rt_base_cycle, avr->frequency);
	if (sim > mono_ns())
		rt_wait(sim);
}
