"""`vehil flash`: program a Mega 2560 through its bootloader with avrdude, then see the
firmware boot.

The Mega's bootloader is stk500v2 at 115200 baud (avrdude's `wiring` programmer, which
also pulses DTR to reset the board). avrdude writes the image and reads it back; a
board that then sends its ready frame and answers HELLO runs what was written.
"""

from __future__ import annotations

import contextlib
import os
import re
import selectors
import shutil
import subprocess
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from vehil.boards.base import Board
from vehil.errors import (
    AvrdudeMissing,
    BuildMissing,
    FlashError,
    NoBootloader,
    NoPort,
    PortBusy,
    UnsupportedBaud,
    VehilError,
    VerifyMismatch,
    WrongSignature,
)
from vehil.link import Link
from vehil.paths import FLASH_DIR

PART = "m2560"
BOOTLOADER_BAUD = 115200  # fixed when the Mega's stk500v2 bootloader is built
AVRDUDE_TIMEOUT_S = 120.0


@dataclass
class FlashResult:
    """What avrdude did: the image, its size, and how long writing and reading back took."""

    image: Path
    port: str
    bytes: int
    seconds: float  # the whole avrdude run, reset and sign-on included
    write_s: float  # avrdude's own figures, from its progress bars
    verify_s: float


def to_hex(elf: Path, out: Path) -> Path:
    """An Intel HEX of the ELF's flash contents (no EEPROM), as avrdude takes it."""
    objcopy = shutil.which("avr-objcopy")
    if objcopy is None:
        raise BuildMissing("avr-objcopy not found: install Debian's binutils-avr")
    out.parent.mkdir(parents=True, exist_ok=True)
    cmd = [objcopy, "-O", "ihex", "-R", ".eeprom", str(elf), str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise FlashError(f"cannot make {out} from {elf}: {proc.stderr.strip()}")
    return out


def firmware_hex(env: str = "offline", *, boot_baud: int | None = None) -> Path:
    """Builds the firmware for ENV (incrementally), its UART booting at `boot_baud` (None:
    the firmware's default), and returns its Intel HEX."""
    from vehil.build.platformio import build_firmware

    return to_hex(build_firmware(env, boot_baud=boot_baud), FLASH_DIR / f"{env}.hex")


def avrdude_port(url: str) -> str:
    """avrdude's -P for a board URL: a device path, or net:HOST:PORT for socket://."""
    if url.startswith("socket://"):
        return "net:" + url[len("socket://") :]
    if "://" in url:
        raise FlashError(f"avrdude cannot reach {url}: give a serial device or socket://")
    return url


_PROGRESS = re.compile(r"(Writing|Reading) \|[^|]*\| 100% ([\d.]+) ?s")
_WRITTEN = re.compile(r"(\d+) bytes of flash written")
_SIGNATURE_EXPECTED = re.compile(r"expected signature for (\S+) is ([0-9A-Fa-f ]+)", re.I)
_SIGNATURE_GOT = re.compile(r"device signature = (0x[0-9A-Fa-f]+)", re.I)
# avrdude 7: "device 0xb3 != input 0x4c at addr 0x1234"; 6: "first mismatch at byte
# 0x1234\n<spaces>0x4c != 0xb3" (the file's byte first).
_HEX = "0x([0-9a-f]+)"
_MISMATCH_7 = re.compile(rf"device {_HEX} != input {_HEX} at addr {_HEX}", re.I)
_MISMATCH_6 = re.compile(rf"first mismatch at byte {_HEX}\s+{_HEX} != {_HEX}", re.I)
# the whole line: avrdude's output is read as it comes, a line may arrive in parts
_CANNOT_OPEN = re.compile(r"(?:can't open device|cannot open port) \"?([^\":]+)\"?: (.*)\n", re.I)
_NO_SYNC = re.compile(
    r"getsync|not in sync|timeout communicating|ReceiveMessage\(\): timeout|"
    r"programmer is not responding|failed to sync",
    re.I,
)


def avrdude_error(output: str, port: str, part: str = PART) -> VehilError:
    """The error a failed avrdude run stands for, from what it printed."""
    tail = "\n".join(output.strip().splitlines()[-12:])
    mismatch = None  # address, expected, got
    if m := _MISMATCH_7.search(output):
        mismatch = int(m[3], 16), int(m[2], 16), int(m[1], 16)
    elif m := _MISMATCH_6.search(output):
        mismatch = int(m[1], 16), int(m[2], 16), int(m[3], 16)
    if mismatch:
        address, expected, got = mismatch
        return VerifyMismatch(
            f"verification failed at address 0x{address:05x}: expected 0x{expected:02x} "
            f"(the image), got 0x{got:02x} (read back from the flash). Flash again; if "
            "the same address fails again, that page of the chip's flash is worn out.",
            address,
            expected,
            got,
        )
    if m := _SIGNATURE_EXPECTED.search(output):
        got_sig = g[1] if (g := _SIGNATURE_GOT.search(output)) else "unknown"
        expected_sig = "0x" + m[2].replace(" ", "").lower()
        return WrongSignature(
            f"wrong device signature on {port}: expected {expected_sig} ({m[1]}, avrdude "
            f"part {part}), got {got_sig}. This is not an ATmega2560 board (an Uno is "
            "0x1e950f, a Mega 1280 0x1e9703): check the port.",
            expected_sig,
            got_sig,
        )
    if m := _CANNOT_OPEN.search(output):
        if "busy" in m[2].lower():
            return PortBusy(
                f"{port} is busy: another program has it open (a serial monitor, another "
                "vehil or avrdude; on Linux, ModemManager probes new ports for a few "
                "seconds after plug-in). Close it and retry."
            )
        return NoPort(f"avrdude cannot open {port}: {m[2].strip()}")
    if _NO_SYNC.search(output):
        return NoBootloader(
            f"no answer from the bootloader on {port} at {BOOTLOADER_BAUD} baud (stk500v2). "
            "Check that it is the Mega's port (not another board's), press the board's "
            "reset button just as avrdude starts, and, on clones with a CH340 USB chip, "
            f"that its driver is loaded.\navrdude said:\n{tail}"
        )
    return FlashError(f"avrdude failed on {port}:\n{tail}")


def _watch(argv: list[str], timeout_s: float) -> tuple[int | None, str]:
    """Runs avrdude and collects what it prints: (exit status, output), or (None,
    output) after the timeout. avrdude 7.1 goes on after a port it cannot open and
    then spins at 100 % CPU for good, so it is stopped as soon as it says so."""
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    assert proc.stdout is not None
    fd = proc.stdout.fileno()
    out = bytearray()
    returncode: int | None = None
    deadline = time.monotonic() + timeout_s
    with selectors.DefaultSelector() as sel:
        sel.register(fd, selectors.EVENT_READ)
        while (left := deadline - time.monotonic()) > 0:
            if not sel.select(left):
                continue
            chunk = os.read(fd, 65536)
            if not chunk:
                returncode = proc.wait()
                break
            out += chunk
            if _CANNOT_OPEN.search(out.decode(errors="replace")):
                returncode = 1
                break
    if proc.poll() is None:
        proc.kill()
        proc.wait()
    proc.stdout.close()
    return returncode, out.decode(errors="replace")


def check_baud(baud: int) -> None:
    if baud != BOOTLOADER_BAUD:
        raise UnsupportedBaud(
            f"the Mega 2560's stk500v2 bootloader talks at {BOOTLOADER_BAUD} baud only (its "
            f"baud is fixed when it is built), not {baud}: drop --baud"
        )


def run_avrdude(
    port: str,
    image: Path,
    *,
    part: str = PART,
    baud: int = BOOTLOADER_BAUD,
    verify_with: Path | None = None,
    timeout_s: float = AVRDUDE_TIMEOUT_S,
) -> FlashResult:
    """Writes IMAGE (Intel HEX) to the flash and verifies it; `verify_with` also
    compares the flash with another image after that."""
    check_baud(baud)
    avrdude = shutil.which("avrdude")
    if avrdude is None:
        raise AvrdudeMissing(
            "avrdude not found: install Debian's avrdude (`sudo apt-get install avrdude`)"
        )
    for path in (image, verify_with):
        if path is not None and not path.is_file():
            raise FlashError(f"no image {path}")
    argv = [avrdude, "-c", "wiring", "-p", part, "-b", str(baud), "-P", port, "-D"]
    argv += ["-U", f"flash:w:{image}:i"]
    if verify_with is not None:
        argv += ["-U", f"flash:v:{verify_with}:i"]
    start = time.monotonic()
    returncode, output = _watch(argv, timeout_s)
    seconds = time.monotonic() - start
    if returncode is None:
        raise NoBootloader(
            f"avrdude did not finish within {timeout_s:.0f} s on {port}: the board stopped "
            "answering. Unplug it, plug it in again and retry."
        )
    if returncode != 0:
        raise avrdude_error(output, port, part)
    written = _WRITTEN.search(output)
    times = {"Writing": 0.0, "Reading": 0.0}
    for m in _PROGRESS.finditer(output):
        times[m[1]] += float(m[2])
    return FlashResult(
        image=image,
        port=port,
        bytes=int(written[1]) if written else 0,
        seconds=seconds,
        write_s=times["Writing"],
        verify_s=times["Reading"],
    )


def check_target(board: Board, baud: int, boot_baud: int | None = None) -> None:
    """What makes flashing fail whatever the image: refused before one is built."""
    if not board.flashable:
        raise FlashError(
            f"the {board.name} board has no bootloader to program: flash "
            "--board simavr-bootloader or a real board (--port PORT)"
        )
    check_baud(baud)
    if boot_baud is not None:
        from vehil.build.platformio import check_boot_baud

        check_boot_baud(boot_baud)
    board.check()


@contextlib.contextmanager
def flashed(
    board: Board,
    image: Path,
    *,
    part: str = PART,
    baud: int = BOOTLOADER_BAUD,
    verify_with: Path | None = None,
    timeout_s: float = AVRDUDE_TIMEOUT_S,
) -> Iterator[tuple[FlashResult, Link]]:
    """Starts the board, programs IMAGE through its bootloader, and yields what avrdude
    did with the link to the firmware it now runs (ready frame seen, INFO read)."""
    check_target(board, baud)
    try:
        url = board.start()
        with board.programmer_port(url) as programmer:
            result = run_avrdude(
                avrdude_port(programmer),
                image,
                part=part,
                baud=baud,
                verify_with=verify_with,
                timeout_s=timeout_s,
            )
        with board.session(url) as link:
            yield result, link
    finally:
        board.stop()
