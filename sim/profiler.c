/* --profile: cycles per function and per call stack, counted by the sim loop
 * after every instruction while a window is open (see sim/README.md,
 * "Profiling").
 *
 * The host gives the functions as address ranges (--profile-map) and the
 * windows as the address ranges that open one (--profile-window), so the
 * bridge knows no symbols.  A window opens when the PC enters one of those
 * ranges, and closes when it leaves them in the frame it entered from (an
 * estimator's step: the range is the call instruction, and the window is the
 * call with all it does); with --profile-window-end, when its outermost frame
 * reaches one of those ranges instead (code marks around inlined code, whose
 * instructions the compiler interleaves with its caller's).  Without
 * --profile-window the whole run is one window, cut into the next one by SIGUSR1.
 *
 * A shadow call stack follows CALL/RCALL/ICALL/EICALL and RET; an interrupt
 * entered is a frame of its own (a marker node for its vector, its code
 * below), left by RETI.  An instruction's cycles go to the function whose
 * code it is, in the frame on top: a jump into another function (a tail
 * call) replaces the frame's function, as a call to it would have; a window
 * stays open while its outermost frame runs another function's code (a jump
 * table in libgcc), and closes when that frame is back in its own function
 * outside the ranges.  simavr
 * 1.6 enters an interrupt in 0 cycles; RETI's cycles are the ISR's.
 *
 * SIGUSR1 ends a segment of the output: the run's window is cut there, and the
 * instructions' totals so far are written and start again.
 *
 * Output, one record a line (hex addresses):
 *   N id parent func   a calling-context node; func >= 0 a function of the
 *                      map (its line index, the map's length for none),
 *                      -1 - v an interrupt with vector v; parent -1: a root
 *   W k cycles how     window k closed ("end"; "cut": SIGUSR1 or exit; "reset")
 *   S node self calls  a node's cycles and entries in that window (after W)
 *   P addr cycles      the segment's cycles of the instruction at addr
 *   C                  the end of a segment (SIGUSR1; the last one ends at exit)
 */
#include "bridge.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#define OP_RET 0x9508u
#define OP_RETI 0x9518u
#define OP_ICALL 0x9509u
#define OP_EICALL 0x9519u
#define MAX_DEPTH 256

struct node {
	int32_t parent;
	int32_t func;
	int32_t first_child;
	int32_t next_sibling;
	uint64_t self;		/* this window */
	uint32_t calls;		/* this window */
	int touched;
};

struct frame {
	int32_t node;
	int isr;
};

static struct {
	FILE *out;
	uint32_t *func_of;	/* per flash word */
	uint32_t n_funcs;	/* the map's length: also the id of "no function" */
	uint8_t *opens;		/* per flash word: in a window range */
	uint8_t *ends;		/* per flash word: closes the window; NULL: leaving opens */
	int run_window;		/* no ranges: the whole run, cut by SIGUSR1 */
	uint64_t *pc_cycles;	/* per flash word, all windows */
	uint32_t n_words;

	struct node *nodes;
	int32_t n_nodes, cap_nodes, dumped_nodes;
	int32_t *touched;
	int32_t n_touched;

	struct frame stack[MAX_DEPTH];
	int depth;		/* 0: no window open */
	uint32_t base_func;	/* the function the window was opened in */
	uint64_t window_cycles;
	uint64_t windows;
} P;

int g_profiling;
atomic_int g_profile_cut;

static int32_t child(int32_t parent, int32_t func)
{
	int32_t first = -1;
	if (parent >= 0) {
		first = P.nodes[parent].first_child;
		for (int32_t c = first; c >= 0; c = P.nodes[c].next_sibling)
			if (P.nodes[c].func == func)
				return c;
	} else {		/* roots: few, searched in order */
		for (int32_t c = 0; c < P.n_nodes; c++)
			if (P.nodes[c].parent < 0 && P.nodes[c].func == func)
				return c;
	}
	if (P.n_nodes == P.cap_nodes) {
		P.cap_nodes = P.cap_nodes ? 2 * P.cap_nodes : 4096;
		P.nodes = realloc(P.nodes, (size_t)P.cap_nodes * sizeof *P.nodes);
		P.touched = realloc(P.touched, (size_t)P.cap_nodes * sizeof *P.touched);
		if (!P.nodes || !P.touched) {
			diag("profile: out of memory (%d call-stack nodes)", P.n_nodes);
			exit(EXIT_SETUP);
		}
	}
	int32_t id = P.n_nodes++;
	P.nodes[id] = (struct node){ .parent = parent, .func = func, .first_child = -1,
		.next_sibling = first };
	if (parent >= 0)
		P.nodes[parent].first_child = id;
	return id;
}

static void touch(int32_t n)
{
	if (!P.nodes[n].touched) {
		P.nodes[n].touched = 1;
		P.touched[P.n_touched++] = n;
	}
}

static void push(int32_t node, int isr)
{
	if (P.depth == MAX_DEPTH) {
		diag("profile: call stack deeper than %d frames at PC=0x%05x", MAX_DEPTH,
			(unsigned)g_avr->pc);
		finish(EXIT_CRASH);
	}
	P.stack[P.depth++] = (struct frame){ node, isr };
	touch(node);
	P.nodes[node].calls++;
}

static uint32_t func_at(avr_flashaddr_t pc)
{
	uint32_t w = pc >> 1;
	return w < P.n_words ? P.func_of[w] : P.n_funcs;
}

static void close_window(const char *how)
{
	for (int32_t i = P.dumped_nodes; i < P.n_nodes; i++)
		fprintf(P.out, "N %d %d %d\n", i, P.nodes[i].parent, P.nodes[i].func);
	P.dumped_nodes = P.n_nodes;
	fprintf(P.out, "W %llu %llu %s\n", (unsigned long long)P.windows,
		(unsigned long long)P.window_cycles, how);
	for (int32_t i = 0; i < P.n_touched; i++) {
		struct node *n = &P.nodes[P.touched[i]];
		fprintf(P.out, "S %d %llu %u\n", P.touched[i], (unsigned long long)n->self, n->calls);
		n->self = 0;
		n->calls = 0;
		n->touched = 0;
	}
	P.n_touched = 0;
	P.window_cycles = 0;
	P.windows++;
}

/* Whether the window's outermost frame, going on to pc, leaves the window. */
static int window_ends(avr_flashaddr_t pc)
{
	int in = pc >> 1 < P.n_words;
	if (P.ends)
		return in && P.ends[pc >> 1];
	return !(in && P.opens[pc >> 1]) && func_at(pc) == P.base_func;
}

/* Where an instruction went on to: the PC, or, if an interrupt was entered
 * right after it, the return address the interrupt pushed. */
static avr_flashaddr_t next_pc(avr_t *avr, int interrupted)
{
	if (!interrupted)
		return avr->pc;
	uint16_t sp = (uint16_t)(avr->data[R_SPL] | avr->data[R_SPH] << 8);
	uint32_t w = 0;
	for (int i = 1; i <= avr->address_size; i++)
		w = w << 8 | avr->data[sp + i];
	return w << 1;
}

void profiler_step(avr_t *avr, avr_flashaddr_t pc0, avr_cycle_count_t c0, uint8_t rp0, int state0)
{
	if (avr->pc == 0 && state0 == cpu_Running && pc0 != 0) {	/* a reset */
		if (P.depth && !P.run_window)
			close_window("reset");
		P.depth = 0;
	}
	if (!P.depth) {
		if (!P.run_window && !(pc0 >> 1 < P.n_words && P.opens[pc0 >> 1]))
			return;
		P.base_func = func_at(pc0);
		int32_t root = child(-1, (int32_t)P.base_func);
		P.stack[P.depth++] = (struct frame){ root, 0 };
		touch(root);
		P.nodes[root].calls++;
	}

	/* the instruction's cycles, to its function in the top frame */
	struct frame *top = &P.stack[P.depth - 1];
	int32_t f = (int32_t)func_at(pc0);
	if (P.nodes[top->node].func != f) {
		int32_t parent = P.nodes[top->node].parent;
		if (P.nodes[top->node].func < 0)	/* an interrupt's marker: its code goes below */
			parent = top->node;
		top->node = child(parent, f);
		touch(top->node);
		P.nodes[top->node].calls++;
	}
	uint64_t dc = avr->cycle - c0;
	touch(top->node);	/* a frame returned to counts in this window too */
	P.nodes[top->node].self += dc;
	P.window_cycles += dc;
	if (pc0 >> 1 < P.n_words)
		P.pc_cycles[pc0 >> 1] += dc;

	/* what it did to the call stack */
	int interrupted = avr->interrupts.running_ptr > rp0;
	avr_flashaddr_t pc1 = next_pc(avr, interrupted);
	if (state0 == cpu_Running && pc0 + 1 <= avr->flashend) {
		uint16_t op = (uint16_t)(avr->flash[pc0] | avr->flash[pc0 + 1] << 8);
		/* "rcall .+0" makes room on the stack: not a call */
		if ((op & 0xfe0eu) == 0x940eu || ((op & 0xf000u) == 0xd000u && op != 0xd000u)
				|| op == OP_ICALL || op == OP_EICALL) {
			push(child(top->node, (int32_t)func_at(pc1)), 0);
		} else if (op == OP_RET || op == OP_RETI) {
			int isr = op == OP_RETI;
			while (P.depth > 0) {
				int was_isr = P.stack[--P.depth].isr;
				if (was_isr == isr || !isr)
					break;
			}
		}
	}
	if (!P.run_window && (P.depth == 0 || (P.depth == 1 && window_ends(pc1)))) {
		close_window("end");
		P.depth = 0;
		return;
	}
	if (P.depth == 0)	/* the run's outermost frame returned */
		P.stack[P.depth++] = (struct frame){ child(-1, (int32_t)func_at(pc1)), 0 };
	if (interrupted) {
		uint8_t v = avr->interrupts.running[avr->interrupts.running_ptr - 1]->vector;
		push(child(P.stack[P.depth - 1].node, -1 - (int32_t)v), 1);
	}
}

/* SIGUSR1 (run window): what ran since the last cut is a window. */
static void dump_pcs(void)
{
	for (uint32_t w = 0; w < P.n_words; w++)
		if (P.pc_cycles[w]) {
			fprintf(P.out, "P %x %llu\n", w << 1, (unsigned long long)P.pc_cycles[w]);
			P.pc_cycles[w] = 0;
		}
}

void profiler_cut(void)
{
	if (P.run_window && P.window_cycles)
		close_window("cut");
	dump_pcs();
	fputs("C\n", P.out);
}

void profiler_finish(void)
{
	if (!g_profiling)
		return;
	if (P.window_cycles)
		close_window("cut");
	dump_pcs();
	if (fclose(P.out) != 0)
		diag("profile: cannot write '%s': %s", opt.profile, strerror(errno));
	g_profiling = 0;
}

/* "LO-HI[,LO-HI...]", hex byte addresses, HI exclusive. */
static int parse_ranges(const char *s, uint8_t *opens, uint32_t n_words)
{
	while (*s) {
		char *end;
		unsigned long lo = strtoul(s, &end, 16), hi;
		if (end == s || *end != '-')
			return -1;
		s = end + 1;
		hi = strtoul(s, &end, 16);
		if (end == s || hi <= lo || hi > 2ul * n_words || (*end && *end != ','))
			return -1;
		memset(opens + lo / 2, 1, (hi + 1) / 2 - lo / 2);
		s = *end ? end + 1 : end;
	}
	return 0;
}

static int read_ranges(const char *flag, const char *s, uint8_t *in)
{
	if (parse_ranges(s, in, P.n_words) == 0)
		return 0;
	diag("%s: bad ranges '%s' (LO-HI[,LO-HI...] in hex, inside the flash)", flag, s);
	return -1;
}

/* The map: one function a line, "START END" in hex byte addresses (END
 * exclusive); its line index is its id. */
static int read_map(const char *path)
{
	FILE *f = fopen(path, "r");
	if (!f) {
		diag("profile: cannot read the function map '%s': %s", path, strerror(errno));
		return -1;
	}
	for (uint32_t w = 0; w < P.n_words; w++)
		P.func_of[w] = UINT32_MAX;
	unsigned long lo, hi;
	uint32_t id = 0;
	int n;
	while ((n = fscanf(f, "%lx %lx", &lo, &hi)) == 2) {
		if (hi < lo || hi > 2ul * P.n_words) {
			diag("profile: function map '%s', line %u: 0x%lx-0x%lx is not in the flash",
				path, id + 1, lo, hi);
			fclose(f);
			return -1;
		}
		for (unsigned long w = lo / 2; w < (hi + 1) / 2; w++)
			P.func_of[w] = id;
		id++;
	}
	int bad = n != EOF;
	fclose(f);
	if (bad) {
		diag("profile: function map '%s', line %u: not 'START END' in hex", path, id + 1);
		return -1;
	}
	P.n_funcs = id;
	for (uint32_t w = 0; w < P.n_words; w++)
		if (P.func_of[w] == UINT32_MAX)
			P.func_of[w] = id;
	return 0;
}

int profiler_setup(avr_t *avr)
{
	P.n_words = (avr->flashend + 1) / 2;
	P.func_of = calloc(P.n_words, sizeof *P.func_of);
	P.opens = calloc(P.n_words, 1);
	P.pc_cycles = calloc(P.n_words, sizeof *P.pc_cycles);
	if (!P.func_of || !P.opens || !P.pc_cycles) {
		diag("profile: out of memory");
		return -1;
	}
	if (read_map(opt.profile_map) != 0)
		return -1;
	P.run_window = !opt.profile_window;
	if (opt.profile_window && read_ranges("--profile-window", opt.profile_window, P.opens) != 0)
		return -1;
	if (opt.profile_window_end) {
		P.ends = calloc(P.n_words, 1);
		if (!P.ends) {
			diag("profile: out of memory");
			return -1;
		}
		if (read_ranges("--profile-window-end", opt.profile_window_end, P.ends) != 0)
			return -1;
	}
	P.out = fopen(opt.profile, "w");
	if (!P.out) {
		diag("profile: cannot write '%s': %s", opt.profile, strerror(errno));
		return -1;
	}
	setvbuf(P.out, NULL, _IOFBF, 1u << 20);
	g_profiling = 1;
	return 0;
}
