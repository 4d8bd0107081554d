"""The native board: the firmware's message core and estimators built for the host."""

from __future__ import annotations

from vehil.boards.base import Board
from vehil.errors import BuildMissing
from vehil.paths import NATIVE_LIB


class NativeBoard(Board):
    name = "native"
    ready_timeout_s = 1.0

    def start(self) -> str:
        if not NATIVE_LIB.exists():
            raise BuildMissing(f"native board library {NATIVE_LIB} is missing: run `vehil build`")
        return "native://"
