"""A real board on a serial port (an Arduino Mega 2560 on /dev/ttyACM0, say),
or any other pyserial URL."""

from __future__ import annotations

import errno
import time

import serial
from serial.tools import list_ports

from vehil.boards.base import Board
from vehil.errors import BoardStartError, BoardTimeout, NoPort, PortBusy
from vehil.link import Link


def ports_seen() -> str:
    ports = [p.device for p in list_ports.comports()]
    return ", ".join(ports) if ports else "none"


class SerialBoard(Board):
    """Opening the port pulses DTR, which resets a Mega: the bootloader runs
    (up to ~1 s) and then the firmware sends its ready frame."""

    ready_timeout_s = 4.0
    flashable = True

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
                raise NoPort(f"no serial port {url}; ports seen: {ports_seen()}") from None
            if code in (errno.EBUSY, errno.EAGAIN) or "lock" in str(exc):
                raise PortBusy(
                    f"{url} is busy: another program (a serial monitor, avrdude, "
                    "another vehil) has it open; close that and retry"
                ) from None
            if code == errno.EACCES:
                raise BoardStartError(
                    f"no permission to open {url}: add yourself to the port's group "
                    "(`sudo usermod -aG dialout $USER`, then log in again)"
                ) from None
            raise BoardStartError(f"cannot open {url}: {exc}") from None

    def enter_bootloader(self, url: str) -> None:
        """A DTR pulse resets a Mega into its bootloader (avrdude's wiring programmer
        pulses again). Opening the port here first says clearly when it is missing or busy."""
        port = self.open_port(url)
        try:
            port.dtr = False
            time.sleep(0.1)
            port.dtr = True
            time.sleep(0.05)
        finally:
            port.close()

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
