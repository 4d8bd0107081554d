"""A real board on a serial port (an Arduino Mega 2560 on /dev/ttyACM0, say),
or any other pyserial URL."""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Iterator

import serial

from vehil.boards.base import Board, BoardOptions, ports_seen
from vehil.errors import BoardTimeout, NoPort
from vehil.link import Link


def reset_pulse(port: serial.SerialBase) -> None:
    """DTR low then high: a Mega's auto-reset circuit resets the chip into its bootloader."""
    port.dtr = False
    time.sleep(0.1)
    port.dtr = True
    time.sleep(0.05)


class SerialBoard(Board):
    """Opening the port pulses DTR, which resets a Mega: the bootloader runs
    (up to ~1 s) and then the firmware sends its ready frame."""

    ready_timeout_s = 4.0
    flashable = True
    exclusive = True

    def __init__(self, port: str, options: BoardOptions | None = None):
        super().__init__(options)
        self.port = port
        self.name = port

    def check(self) -> None:
        if self.port.startswith("/dev/") and not os.path.exists(self.port):
            raise NoPort(f"no serial port {self.port}; ports seen: {ports_seen()}")

    def start(self) -> str:
        return self.port

    @contextlib.contextmanager
    def programmer_port(self, url: str) -> Iterator[str]:
        """A DTR pulse resets a Mega into its bootloader (avrdude's wiring programmer
        pulses again). Opening the port here first says clearly when it is missing or busy."""
        port = self.open_port(url)
        try:
            reset_pulse(port)
        finally:
            port.close()
        yield url

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
                    f"opening at {self.baud} baud, and no answer to HELLO. The link opens at "
                    f"the firmware's boot rate ({self._whose_rate()}; --baud switches it only "
                    "once connected): check that this is the board's port, that the vehil "
                    "firmware is flashed (`vehil flash`), and the cable."
                ) from None

    def _whose_rate(self) -> str:
        if self.options.boot_baud is not None:
            return "as --boot-baud gives it"
        built = f"{self.elf}'s" if self.elf.exists() else "the default"
        return f"{built}; give --boot-baud if the board runs an image built with another"
