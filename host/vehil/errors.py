"""Errors a user can act on. Each message says what happened and what to do."""

from __future__ import annotations


class VehilError(Exception):
    """Base of every error vehil reports to a user."""


class BuildMissing(VehilError):
    """A build product (firmware image, simulator, native library) is not there."""


class BoardStartError(VehilError):
    """A board could not be started or reached."""


class LinkError(VehilError):
    """The serial link failed: timeout, lost or out-of-order reply, garbage."""


class BoardTimeout(LinkError):
    """The board did not answer in time."""


class BoardReset(LinkError):
    """The board announced itself again mid-session: it rebooted."""


class ProtocolMismatch(LinkError):
    """Host and firmware speak different protocol versions."""


class BoardError(VehilError):
    """The board refused a request with an ERROR reply."""

    def __init__(self, message: str, code: str, request: str, detail: int):
        super().__init__(message)
        self.code = code
        self.request = request
        self.detail = detail


class PlantLimit(VehilError):
    """A plant driven past what its model can simulate: it says so instead of going NaN."""


class NotInImage(VehilError):
    """The board's firmware image does not hold the estimator asked for."""


class NotComparable(VehilError):
    """Two recordings that are not runs of one drive."""


class BuildError(VehilError):
    """A build step (compiler, PlatformIO, make) failed."""


class NoPort(BoardStartError):
    """No serial port of that name (or none given)."""


class PortBusy(BoardStartError):
    """Another program has the serial port open."""


class FlashError(VehilError):
    """avrdude could not program the board, or the board does not hold the image."""


class AvrdudeMissing(FlashError):
    """avrdude is not installed."""


class UnsupportedBaud(FlashError):
    """The bootloader does not talk at that baud rate."""


class NoBootloader(FlashError):
    """avrdude got no answer from the bootloader."""


class WrongSignature(FlashError):
    """The chip is not the part avrdude was told to program."""

    def __init__(self, message: str, expected: str, got: str):
        super().__init__(message)
        self.expected = expected
        self.got = got


class VerifyMismatch(FlashError):
    """The flash read back differs from the image."""

    def __init__(self, message: str, address: int, expected: int, got: int):
        super().__init__(message)
        self.address = address
        self.expected = expected
        self.got = got


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP (a CI timeout, a closed terminal): ends a run as Ctrl-C does."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum
