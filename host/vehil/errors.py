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


class BuildError(VehilError):
    """A build step (compiler, PlatformIO, make) failed."""
