/* --vcd: UART0 bytes, XOFF, sleep and the I/O ports in a VCD trace. */
#include "bridge.h"

#include <stdlib.h>

#include <avr_ioport.h>

static const char *sig_names[SIG_COUNT] = {
	[SIG_TX] = "8>uart0_tx", [SIG_TX_STB] = "1>uart0_tx_strobe",
	[SIG_RX] = "8>uart0_rx", [SIG_RX_STB] = "1>uart0_rx_strobe",
	[SIG_XOFF] = "1>uart0_xoff", [SIG_SLEEP] = "1>cpu_sleeping",
};
avr_irq_t *g_sig;		/* NULL unless --vcd */
avr_vcd_t g_vcd;
int g_vcd_open;

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

void setup_vcd(avr_t *avr)
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
