/* The firmware ELF: checked before simavr reads it, then its flash image
 * built from the loadable segments. */
#include "bridge.h"

#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <gelf.h>
#include <libelf.h>

/* Checks that the file exists and is a 32-bit AVR ELF before handing it to
 * simavr, whose loader gives poor messages (or none) on bad input. */
void check_elf_file(const char *path)
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
int load_flash_segments(const char *path, elf_firmware_t *fw)
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
