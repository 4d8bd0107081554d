"""`mega16u2://INNER`: a port that passes board->host bytes on as an Arduino Mega 2560's
ATmega16U2 USB bridge does.

The Mega's chip talks to the host through a second microcontroller, the ATmega16U2,
running Arduino's usbserial firmware (LUFA's CDC class). Its main loop moves bytes
from its USART buffer to the USB IN endpoint only when its Timer0 overflows
(prescaler 256: every 4.096 ms) or when more than 96 bytes are waiting, and then
sends everything waiting, in 64-byte USB packets. So a reply reaches the host up to
4.1 ms after the chip sent it, whatever the baud, unless a burst of more than 96
bytes pushes it out sooner. Host->board bytes go straight through (the 16U2 writes
them to its USART as they come). Wrapping simavr-realtime's pty (the chip at its real
pace) in this gives the loop rates a user gets on a real Mega.

Not modelled: the bootloader's ~0.8 s wait after the DTR reset (the chip starts when
the port is opened, as the reset leaves it, but straight in the firmware:
simavr-bootloader runs the real bootloader); the 16U2's 128-byte buffer overflowing
when the host stops reading (here nothing is lost); USB scheduling (packets are
delivered as soon as they are released); the 16U2's own baud error (it uses the same
UBRR as the chip, so the two agree).
"""

from __future__ import annotations

import threading
import time
from collections import deque

from serial.serialutil import SerialException

from vehil.transports.wrapping import WrappingSerial

FLUSH_PERIOD_S = 256 * 256 / 16e6  # Timer0 overflow, prescaler 256: 4.096 ms
NEAR_FULL = 96  # more than this many bytes waiting: sent at once
PACKET = 64  # full-speed bulk endpoint size


class Serial(WrappingSerial):
    """A serial port whose board->host bytes are held and released like the 16U2's."""

    scheme = "mega16u2"

    def open(self) -> None:
        self._open_inner(self._inner_url(), timeout=0.0005)
        self._waiting = bytearray()  # in the 16U2's USART buffer
        self._packets: deque[bytes] = deque()  # released to the host
        self.packets_sent = 0
        self._ready = threading.Condition()
        self._running = True
        self._error: Exception | None = None
        self._pump = threading.Thread(target=self._run, name="mega16u2", daemon=True)
        self.is_open = True
        self._pump.start()

    def _run(self) -> None:
        """The 16U2's main loop: collect the chip's bytes; on the timer or past 96, send."""
        assert self._inner is not None
        next_flush = time.perf_counter() + FLUSH_PERIOD_S
        while self._running:
            try:
                data = self._inner.read(max(1, self._inner.in_waiting))
            except (SerialException, OSError) as exc:
                with self._ready:
                    self._error = exc
                    self._ready.notify_all()
                return
            self._waiting += data
            now = time.perf_counter()
            if now >= next_flush or len(self._waiting) > NEAR_FULL:
                if now >= next_flush:
                    next_flush += FLUSH_PERIOD_S * (1 + int((now - next_flush) / FLUSH_PERIOD_S))
                if self._waiting:
                    with self._ready:
                        for i in range(0, len(self._waiting), PACKET):
                            self._packets.append(bytes(self._waiting[i : i + PACKET]))
                            self.packets_sent += 1
                        self._waiting.clear()
                        self._ready.notify_all()

    def close(self) -> None:
        self._running = False
        if getattr(self, "_pump", None) is not None and self._pump.is_alive():
            self._pump.join(timeout=1.0)
        super().close()

    @property
    def in_waiting(self) -> int:
        self._require_open()
        with self._ready:
            return sum(len(p) for p in self._packets)

    def read(self, size: int = 1) -> bytes:
        self._require_open()
        deadline = None if self._timeout is None else time.perf_counter() + self._timeout
        out = bytearray()
        with self._ready:
            while len(out) < size:
                if self._packets:
                    packet = self._packets.popleft()
                    take = size - len(out)
                    out += packet[:take]
                    if take < len(packet):
                        self._packets.appendleft(packet[take:])
                    continue
                if self._error is not None:
                    raise SerialException(f"the board's port failed: {self._error}")
                if out:
                    break
                left = None if deadline is None else deadline - time.perf_counter()
                if left is not None and left <= 0:
                    break
                self._ready.wait(left)
        return bytes(out)

    def write(self, data: bytes) -> int:
        return int(self._require_open().write(data))

    def reset_input_buffer(self) -> None:
        with self._ready:
            self._packets.clear()
        super().reset_input_buffer()
