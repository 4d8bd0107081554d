"""What every board does: start, connect by URL, wait for ready, stop."""

from __future__ import annotations

import contextlib
import errno
import functools
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import serial
from serial.tools import list_ports

import vehil.transports  # noqa: F401  (registers native://)
from vehil.errors import BoardStartError, BoardTimeout, LinkError, NoPort, PortBusy
from vehil.link import Link
from vehil.paths import FIRMWARE_ELF

DEFAULT_BAUD = 1_000_000
_RETRY_OPEN_S = 0.02


def image_boot_baud(elf: Path) -> int:
    """The rate an image's UART boots at: the vehil_boot_baud symbol `vehil build
    --boot-baud` puts in the ELF, else the firmware's default."""
    if not elf.exists():
        return DEFAULT_BAUD
    return _symbol_baud(elf, elf.stat().st_mtime_ns)


@functools.cache
def _symbol_baud(elf: Path, _mtime_ns: int) -> int:
    from elftools.elf.elffile import ELFFile
    from elftools.elf.sections import SymbolTableSection

    with elf.open("rb") as f:
        symtab = ELFFile(f).get_section_by_name(".symtab")
        if not isinstance(symtab, SymbolTableSection):
            return DEFAULT_BAUD
        found = symtab.get_symbol_by_name("vehil_boot_baud")
        return int(found[0]["st_value"]) if found else DEFAULT_BAUD


@dataclass(frozen=True, kw_only=True)
class BoardOptions:
    """What any board takes: the rate its firmware boots at (None: its image's), the rate
    to switch the link to once connected (None: stay), the link's reply timeout, and
    faults to inject."""

    boot_baud: int | None = None
    baud: int | None = None
    timeout_s: float = 2.0
    faults: str | None = None  # a faults:// spec, e.g. "drop=1e-3,seed=1"; armed once up


def ports_seen() -> str:
    ports = [p.device for p in list_ports.comports()]
    return ", ".join(ports) if ports else "none"


def port_error(url: str, exc: serial.SerialException) -> BoardStartError:
    """What a port that does not open means, and what to do about it."""
    cause = exc.__context__ if isinstance(exc.__context__, OSError) else None
    code = getattr(cause, "errno", None) or getattr(exc, "errno", None)
    if code == errno.ENOENT:
        return NoPort(f"no serial port {url}; ports seen: {ports_seen()}")
    if code in (errno.EBUSY, errno.EAGAIN) or "lock" in str(exc):
        return PortBusy(
            f"{url} is busy: another program (a serial monitor, avrdude, "
            "another vehil) has it open; close that and retry"
        )
    if code == errno.EACCES:
        return BoardStartError(
            f"no permission to open {url}: add yourself to the port's group "
            "(`sudo usermod -aG dialout $USER`, then log in again)"
        )
    return BoardStartError(f"cannot open {url}: {exc}")


class Board:
    """A place the firmware runs. Subclasses start it and say its URL."""

    name = "board"
    ready_timeout_s = 10.0
    max_frames_in_flight: int | None = None  # None: as many as the board's RX buffer holds
    flashable = False  # has a bootloader that avrdude can program (`vehil flash`)
    exclusive = False  # open the port for us alone (a real device)
    connect_timeout_s = 0.0  # how long a port that does not open yet is tried again
    elf = FIRMWARE_ELF  # the image it runs, or the one `vehil flash` puts on it

    def __init__(self, options: BoardOptions | None = None):
        self.options = options or BoardOptions()

    @property
    def baud(self) -> int:
        """The rate the link opens at: the firmware's boot rate, as given or as its image says."""
        return self.options.boot_baud or image_boot_baud(self.elf)

    def port_url(self, url: str) -> str:
        """The URL to open: the board's own, or wrapped in a fault injector."""
        if not self.options.faults:
            return url
        from vehil.transports.protocol_faults import wrap_url

        try:
            return wrap_url(url, self.options.faults)
        except ValueError as exc:
            raise BoardStartError(f"--faults {self.options.faults!r}: {exc}") from None

    def check(self) -> None:
        """Refuses what can be refused before anything is built or started."""

    def start(self) -> str:
        """Brings the board up; returns the pyserial URL to reach it."""
        raise NotImplementedError

    def stop(self) -> None:
        """Takes the board down; safe to call twice and after a failed start."""

    @contextlib.contextmanager
    def programmer_port(self, url: str) -> Iterator[str]:
        """The URL avrdude programs the board through, its bootloader answering there."""
        yield url

    def open_port(self, url: str) -> serial.SerialBase:
        """Opens the board's port, tried again for `connect_timeout_s` (a board that is
        still starting, or whose port comes back after a reset)."""
        deadline = time.monotonic() + self.connect_timeout_s
        while True:
            try:
                return serial.serial_for_url(
                    self.port_url(url), baudrate=self.baud, timeout=0.02, exclusive=self.exclusive
                )
            except serial.SerialException as exc:
                self.check_alive()
                if time.monotonic() >= deadline:
                    raise self.port_error(url, exc) from None
            time.sleep(_RETRY_OPEN_S)

    def check_alive(self) -> None:
        """Raises if the board went away for good while its port was being opened."""

    def port_error(self, url: str, exc: serial.SerialException) -> BoardStartError:
        return port_error(url, exc)

    def wait_ready(self, link: Link) -> None:
        try:
            link.wait_ready(self.ready_timeout_s)
        except BoardTimeout as exc:
            raise BoardTimeout(f"{self.name}: {exc}{self.diagnostics()}") from None

    def diagnostics(self) -> str:
        """Anything the board's process said, to append to an error."""
        return ""

    @contextlib.contextmanager
    def session(self, url: str | None = None) -> Iterator[Link]:
        """Starts the board (unless `url` says it is up already) and opens its link."""
        try:
            if url is None:
                url = self.start()
            link = Link(
                self.open_port(url),
                timeout_s=self.options.timeout_s,
                max_frames=self.max_frames_in_flight,
            )
            try:
                self.wait_ready(link)
                link.hello()
                assert link.info is not None
                if self.options.baud is not None and self.options.baud != link.info.fields["baud"]:
                    link.set_baud(self.options.baud)
                arm = getattr(link.port, "arm", None)
                if arm is not None:
                    arm()  # faults start now that the board is up
                yield link
            except LinkError as exc:
                if type(exc) is LinkError:  # say what the board's process said, if anything
                    raise LinkError(f"{exc}{self.diagnostics()}") from exc
                raise
            finally:
                link.close()
        finally:
            self.stop()
