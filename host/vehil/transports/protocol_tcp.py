"""`tcp://HOST:PORT`: pyserial's `socket://`, except that opening the port keeps what has
already arrived, and `in_waiting` counts the bytes waiting (`socket://`'s says 1 when
there are any, so a reader asking for what is waiting took a frame a byte at a time, two
system calls each: ~0.25 ms more a 30-byte reply on a loaded host).

`socket://`'s open() ends by discarding its input (`reset_input_buffer`). QEMU started
with `wait=on` runs the chip from the moment the host connects, so the board's boot INFO
can arrive before open() returns and be thrown away; the board then looks as if it never
booted (3 of 12 QEMU starts on a loaded 2-core host).
"""

from __future__ import annotations

import fcntl
import select
import struct
import termios

from serial.urlhandler import protocol_socket

_RECV_MAX = 65536


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

    @property
    def in_waiting(self) -> int:
        if not self.is_open:
            raise protocol_socket.PortNotOpenError()
        held = fcntl.ioctl(self._socket.fileno(), termios.FIONREAD, struct.pack("i", 0))
        return int(struct.unpack("i", held)[0])

    def read_waiting(self) -> bytes:
        """Every byte that has arrived, at least one, waiting up to the timeout (b"" then),
        in one select and one recv: Link reads replies with it, where
        read(max(1, in_waiting)) took a select and a one-byte recv, then an ioctl, a select
        and a recv for the rest of the frame (~9 us more a reply)."""
        if not self.is_open:
            raise protocol_socket.PortNotOpenError()
        try:
            ready, _, _ = select.select([self._socket], [], [], self._timeout)
            data = self._socket.recv(_RECV_MAX) if ready else None
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError as exc:
            raise protocol_socket.SerialException(f"read failed: {exc}") from None
        if data is None:
            return b""
        if not data:
            raise protocol_socket.SerialException("socket disconnected")
        return data
