"""The part every vehil port that wraps another one shares (`faults://INNER`,
`mega16u2://INNER`): its URL's scheme checked, the inner port opened and closed, settings
and buffer resets passed down."""

from __future__ import annotations

import serial
from serial.serialutil import PortNotOpenError, SerialBase, SerialException


class WrappingSerial(SerialBase):
    scheme = ""  # a subclass's URL scheme
    _inner: serial.SerialBase | None = None

    def _inner_url(self) -> str:
        """What follows SCHEME://, once this port is known to be closed and of its scheme."""
        if self.is_open:  # type: ignore[has-type]
            raise SerialException("port already open")
        text = str(self.portstr)
        prefix = f"{self.scheme}://"
        if not text.startswith(prefix):
            raise SerialException(f"expected a {prefix} URL, got {text!r}")
        return text[len(prefix) :]

    def _open_inner(self, url: str, timeout: float | None) -> None:
        self._inner = serial.serial_for_url(
            url, baudrate=self._baudrate, timeout=timeout, exclusive=self._exclusive
        )

    def _require_open(self) -> serial.SerialBase:
        """The inner port; PortNotOpenError if this one is closed."""
        if self._inner is None:
            raise PortNotOpenError()
        return self._inner

    def close(self) -> None:
        if self._inner is not None:
            self._inner.close()
            self._inner = None
        self.is_open = False

    def _reconfigure_port(self) -> None:
        if self._inner is not None:
            self._inner.baudrate = self._baudrate

    def reset_input_buffer(self) -> None:
        if self._inner is not None:
            self._inner.reset_input_buffer()

    def reset_output_buffer(self) -> None:
        if self._inner is not None:
            self._inner.reset_output_buffer()
