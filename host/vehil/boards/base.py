"""What every board does: start, connect by URL, wait for ready, stop."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import serial

import vehil.transports  # noqa: F401  (registers native://)
from vehil.errors import BoardStartError, BoardTimeout, LinkError
from vehil.link import Link

DEFAULT_BAUD = 1_000_000


class Board:
    """A place the firmware runs. Subclasses start it and say its URL."""

    name = "board"
    ready_timeout_s = 10.0
    max_frames_in_flight: int | None = None  # None: as many as the board's RX buffer holds
    flashable = False  # has a bootloader that avrdude can program (`vehil flash`)

    def __init__(
        self, *, baud: int = DEFAULT_BAUD, timeout_s: float = 2.0, faults: str | None = None
    ):
        self.baud = baud
        self.timeout_s = timeout_s
        self.faults = faults  # a faults:// spec, e.g. "drop=1e-3,seed=1"; armed once up

    def port_url(self, url: str) -> str:
        """The URL to open: the board's own, or wrapped in a fault injector."""
        if not self.faults:
            return url
        from vehil.transports.protocol_faults import wrap_url

        try:
            return wrap_url(url, self.faults)
        except ValueError as exc:
            raise BoardStartError(f"--faults {self.faults!r}: {exc}") from None

    def start(self) -> str:
        """Brings the board up; returns the pyserial URL to reach it."""
        raise NotImplementedError

    def stop(self) -> None:
        """Takes the board down; safe to call twice and after a failed start."""

    def enter_bootloader(self, url: str) -> None:
        """Before avrdude runs: make sure the bootloader is what answers."""

    def open_port(self, url: str) -> serial.SerialBase:
        try:
            return serial.serial_for_url(self.port_url(url), baudrate=self.baud, timeout=0.02)
        except serial.SerialException as exc:
            raise BoardStartError(f"cannot open {self.name} at {url}: {exc}") from None

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
            link = Link(self.open_port(url), timeout_s=self.timeout_s)
            if self.max_frames_in_flight is not None:
                link.max_frames = self.max_frames_in_flight
            try:
                self.wait_ready(link)
                link.hello()
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
