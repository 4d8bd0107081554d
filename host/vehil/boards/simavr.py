"""The simavr board: sim/'s bridge runs the firmware ELF on a cycle-exact ATmega2560."""

from __future__ import annotations

from pathlib import Path

from vehil.boards.base import Board
from vehil.boards.process import BoardProcess
from vehil.errors import BuildMissing
from vehil.paths import FIRMWARE_ELF, SIMAVR_BRIDGE

_READY_PREFIX = "vehil-simavr: listening url="


class SimavrBoard(Board):
    name = "simavr"

    def __init__(
        self,
        *,
        elf: Path = FIRMWARE_ELF,
        realtime: bool = False,
        vcd: Path | None = None,
        gdb_port: int | None = None,
        **options: object,
    ):
        super().__init__(**options)  # type: ignore[arg-type]
        self.elf = elf
        self.extra = (["--realtime"] if realtime else []) + (["--vcd", str(vcd)] if vcd else [])
        if gdb_port is not None:
            self.extra += ["--gdb", str(gdb_port)]
        self.process: BoardProcess | None = None

    def start(self) -> str:
        for path, what in ((SIMAVR_BRIDGE, "simavr bridge"), (self.elf, "firmware image")):
            if not path.exists():
                raise BuildMissing(f"{what} {path} is missing: run `vehil build`")
        self.process = BoardProcess([str(SIMAVR_BRIDGE), *self.extra, str(self.elf)], "simavr")
        line = self.process.read_line(timeout_s=10.0)
        if not line.startswith(_READY_PREFIX):
            raise self.process.failure(f"printed {line!r} instead of its URL")
        return line[len(_READY_PREFIX) :]

    def diagnostics(self) -> str:
        if self.process is None:
            return ""
        tail = self.process.stderr_tail()
        state = "running" if self.process.alive() else f"exited ({self.process.proc.returncode})"
        return f"\nsimavr is {state}" + (f"; it said:\n{tail}" if tail else "")

    def stop(self) -> None:
        if self.process is not None:
            self.process.stop()
            self.process = None
