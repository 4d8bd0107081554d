"""`native://[PATH]`: the firmware's message core built for the host, in-process.

The shared library (firmware/lib + firmware/native) is driven through a byte
pipe, so everything above the link sees an ordinary serial port. The library
holds one board; opening the port powers it on (it then sends its ready INFO).
"""

from __future__ import annotations

import ctypes
import threading
import time
import urllib.parse
from pathlib import Path

from serial.serialutil import PortNotOpenError, SerialBase, SerialException

from vehil.paths import NATIVE_LIB

_loaded: dict[Path, ctypes.CDLL] = {}
# The library's board is global state, and ctypes lets go of the interpreter's lock for
# each call: a port read on one thread while another writes (mega16u2://'s pump) could
# interleave the two inside the C, and frames came out cut or corrupt (58 bad and ~1,100
# lost in 200,000 PINGs). One call at a time.
_calls = threading.Lock()


def load_library(path: Path = NATIVE_LIB) -> ctypes.CDLL:
    path = path.resolve()
    if path not in _loaded:
        if not path.exists():
            raise SerialException(
                f"native board library {path} is missing: build it with `vehil build`"
            )
        lib = ctypes.CDLL(str(path))
        lib.vehil_native_write.argtypes = [ctypes.c_char_p, ctypes.c_uint32]
        lib.vehil_native_read.argtypes = [ctypes.c_char_p, ctypes.c_uint32]
        lib.vehil_native_read.restype = ctypes.c_uint32
        lib.vehil_native_dropped.restype = ctypes.c_uint32
        _loaded[path] = lib
    return _loaded[path]


class Serial(SerialBase):
    """A serial port whose other end is the native board."""

    _lib: ctypes.CDLL | None = None
    _stash = b""  # read from the library, not yet taken by read()

    def open(self) -> None:
        if self.is_open:  # type: ignore[has-type]
            raise SerialException("port already open")
        parsed = urllib.parse.urlsplit(self.portstr or "native://")
        if parsed.scheme != "native":
            raise SerialException(f"expected a native:// URL, got {self.portstr!r}")
        path = Path(parsed.netloc + parsed.path) if (parsed.netloc or parsed.path) else NATIVE_LIB
        self._lib = load_library(path)
        self._buffer = ctypes.create_string_buffer(65536)
        self._stash = b""
        with _calls:
            self._lib.vehil_native_power_on()
        self.is_open = True

    def close(self) -> None:
        self.is_open = False
        self._lib = None

    def _reconfigure_port(self) -> None:
        """Baud rate and framing mean nothing in-process."""

    def _pending(self) -> bytes:
        if self._lib is None:
            raise PortNotOpenError()
        with _calls:
            n = self._lib.vehil_native_read(self._buffer, len(self._buffer))
            return self._buffer.raw[:n]

    @property
    def in_waiting(self) -> int:
        data = self._pending()
        self._stash += data
        return len(self._stash)

    def read(self, size: int = 1) -> bytes:
        self._stash += self._pending()
        if not self._stash and self._timeout:
            # Nothing can arrive unless the host writes: waiting is all a timeout means here.
            time.sleep(self._timeout)
        data, self._stash = self._stash[:size], self._stash[size:]
        return data

    def write(self, data: bytes) -> int:
        if self._lib is None:
            raise PortNotOpenError()
        data = bytes(data)
        with _calls:
            self._lib.vehil_native_write(data, len(data))
        return len(data)

    def reset_input_buffer(self) -> None:
        self._stash = b""
        self._pending()

    def reset_output_buffer(self) -> None:
        """Writes are delivered at once; nothing waits."""
