"""`tcp://HOST:PORT`: pyserial's `socket://`, except that opening the port keeps what has
already arrived.

`socket://`'s open() ends by discarding its input (`reset_input_buffer`). QEMU started
with `wait=on` runs the chip from the moment the host connects, so the board's boot INFO
can arrive before open() returns and be thrown away; the board then looks as if it never
booted (3 of 12 QEMU starts on a loaded 2-core host).
"""

from __future__ import annotations

from serial.urlhandler import protocol_socket


class Serial(protocol_socket.Serial):
    _opening = False

    def open(self) -> None:
        self._opening = True
        try:
            super().open()
        finally:
            self._opening = False

    def reset_input_buffer(self) -> None:
        if not self._opening:
            super().reset_input_buffer()

    def from_url(self, url: str) -> tuple[str, int]:
        scheme, sep, rest = url.partition("://")
        if scheme != "tcp" or not sep:
            raise protocol_socket.SerialException(f"expected tcp://HOST:PORT, got {url!r}")
        return super().from_url("socket://" + rest)  # type: ignore[no-any-return]
