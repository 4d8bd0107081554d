"""The offline image's linker script: avr-ld's own, with `.data` loaded low.

avr-libc's start-up copies the initialised RAM data from flash with ELPM. QEMU 7.2
(Debian 12) ignores RAMPZ in ELPM (fixed in 8.0 by "target/avr: fix long address
calculation"), so data loaded from above 64 KB starts wrong on the qemu board. avr-ld
loads `.data` after all the code; this script ends `.text` after the start-up code
(vectors, tables, .init*), loads `.data` there, and puts the rest of the code in an
output section `.code` after it. The flash tables (`.progmem*`, read with LPM and a
16-bit Z: firmware/lib/rom/rom.h) sit in that low `.text` too; the script asserts that
it ends below 64 KB. `.data` starts with the UART's rings (section `.data.rings`,
firmware/src/uart.c) at the start of RAM, 0x200: they must each lie on a 256-byte
boundary (the interrupts address a slot by its index alone), and there that costs no
padding. The script is derived at build time from the
installed linker's default, so it follows whatever binutils is installed.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

CODE_SECTION = ".code"
RINGS_SECTION = ".data.rings"

_DATA = re.compile(r"^[ \t]*\.data[ \t]*:[ \t]*\n.*?\}[ \t]*> data AT> text[ \t]*\n", re.M | re.S)
_CODE_START = re.compile(r"^[ \t]*\*\(\.text\)[ \t]*\n", re.M)


_DATA_START = re.compile(r"^[ \t]*PROVIDE \(__data_start = \.\) ;[ \t]*\n", re.M)
_RINGS = f"    *({RINGS_SECTION})\n"

_BELOW_64K = (
    '  ASSERT(ADDR(.text) + SIZEOF(.text) + SIZEOF(.data) <= 0x10000, "vehil: the flash '
    "tables (.progmem), start-up code and .data's load image must end below 64 KB, "
    "where LPM and QEMU's ELPM reach them\")\n"
)


class LinkerScriptError(RuntimeError):
    pass


def default_script(mcu: str) -> str:
    """avr-ld's built-in script for the MCU's architecture (avr6 for the ATmega2560)."""
    arch = subprocess.run(
        ["avr-gcc", f"-mmcu={mcu}", "-print-multi-directory"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    out = subprocess.run(
        ["avr-ld", "-m", arch, "--verbose"], capture_output=True, text=True, check=True
    ).stdout
    parts = out.split("=" * 50)
    if len(parts) < 3:
        raise LinkerScriptError(f"`avr-ld -m {arch} --verbose` printed no script:\n{out}")
    return parts[1].strip("\n") + "\n"


def data_low(script: str) -> str:
    """`script` with `.data` loaded between the start-up code and the rest of the code."""
    data = _DATA.search(script)
    code = _CODE_START.search(script)
    if data is None or code is None or code.start() > data.start():
        raise LinkerScriptError(
            "avr-ld's default script does not have the expected shape (a `.text` section "
            "with `*(.text)`, then `.data ... > data AT> text`): cannot place .data low"
        )
    start = _DATA_START.search(data.group(0))
    if start is None:
        raise LinkerScriptError(
            "avr-ld's default script's `.data` does not begin with `PROVIDE (__data_start = .)`:"
            " cannot put the UART rings first"
        )
    return (
        script[: code.start()]
        + "  }  > text\n"
        + _BELOW_64K
        + data.group(0)[: start.end()]
        + _RINGS
        + data.group(0)[start.end() :]
        + f"  {CODE_SECTION}   :\n  {{\n"
        + script[code.start() : data.start()]
        + script[data.end() :]
    )


def write_script(build_dir: Path, mcu: str) -> Path:
    path = build_dir / "vehil.ld"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(data_low(default_script(mcu)))
    return path
