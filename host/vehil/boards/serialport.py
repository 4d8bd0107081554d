"""A real board on a serial port (an Arduino Mega 2560 on /dev/ttyACM0, say),
or any other pyserial URL."""

from __future__ import annotations

import errno

import serial
from serial.tools import list_ports

from vehil.boards.base import Board
from vehil.errors import BoardStartError, BoardTimeout
from vehil.link import Link


def _ports_seen() -> str:
    ports = [p.device for p in list_ports.comports()]
    return ", ".join(ports) if ports else "none"


class SerialBoard(Board):
    """Opening the port pulses DTR, which resets a Mega: the bootloader runs
    (up to ~1 s) and then the firmware sends its ready frame."""

    ready_timeout_s = 4.0

    def __init__(self, port: str, **options: object):
        super().__init__(**options)  # type: ignore[arg-type]
        self.port = port
        self.name = port

    def start(self) -> str:
        return self.port

    def open_port(self, url: str) -> serial.SerialBase:
        try:
            return serial.serial_for_url(
                self.port_url(url), baudrate=self.baud, timeout=0.02, exclusive=True
            )
        except serial.SerialException as exc:
            cause = exc.__context__ if isinstance(exc.__context__, OSError) else None
            code = getattr(cause, "errno", None) or getattr(exc, "errno", None)
            if code == errno.ENOENT:
                raise BoardStartError(
                    f"no serial port {url}; ports seen: {_ports_seen()}"
                ) from None
            if code in (errno.EBUSY, errno.EAGAIN) or "lock" in str(exc):
                raise BoardStartError(
                    f"{url} is busy: another program (a serial monitor, avrdude, "
                    "another vehil) has it open; close that and retry"
                ) from None
            if code == errno.EACCES:
                raise BoardStartError(
                    f"no permission to open {url}: add yourself to the port's group "
                    "(`sudo usermod -aG dialout $USER`, then log in again)"
                ) from None
            raise BoardStartError(f"cannot open {url}: {exc}") from None

    def wait_ready(self, link: Link) -> None:
        """Waits for the boot frame; a board that did not reset on open is asked directly."""
        try:
            link.wait_ready(self.ready_timeout_s)
        except BoardTimeout:
            try:
                link.hello()
            except BoardTimeout:
                raise BoardTimeout(
                    f"{self.port}: no ready frame within {self.ready_timeout_s:.0f} s after "
                    f"opening at {self.baud} baud, and no answer to HELLO. Tried: waiting "
                    "for the boot frame, then HELLO. Check the baud rate (--baud), that the "
                    "vehil firmware is flashed (`vehil flash`), and the cable."
                ) from None
