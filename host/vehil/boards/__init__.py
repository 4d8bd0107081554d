"""Boards: where the firmware runs, each reached through a pyserial URL.

`open_board(spec)` takes a name in VIRTUAL_BOARDS, `labgrid:PLACE` (a place of a
labgrid board farm, boards/labgrid.py), or anything pyserial can open (a device such
as /dev/ttyACM0, or a URL such as socket://host:port), and
returns a context manager that starts the board, waits for its ready frame,
yields a Link with the board's INFO read, and stops the board on the way out,
on errors and Ctrl-C too.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vehil.boards.base import Board, BoardOptions, ports_seen
from vehil.boards.native import NativeBoard
from vehil.boards.qemu import QemuBoard, QemuEvBoard
from vehil.boards.serialport import SerialBoard
from vehil.boards.simavr import (
    SimavrBoard,
    SimavrBootloaderBoard,
    SimavrEvBoard,
    SimavrMegaBoard,
    SimavrOptions,
    SimavrRealtimeBoard,
)
from vehil.errors import NoPort

if TYPE_CHECKING:
    from vehil.boards.labgrid import LabgridOptions

VIRTUAL_BOARDS: dict[str, type[Board]] = {
    "simavr": SimavrBoard,
    "simavr-realtime": SimavrRealtimeBoard,
    "simavr-mega": SimavrMegaBoard,
    "simavr-bootloader": SimavrBootloaderBoard,
    "simavr-ev": SimavrEvBoard,
    "qemu": QemuBoard,
    "qemu-ev": QemuEvBoard,
    "native": NativeBoard,
}
DEFAULT_BOARD = "simavr"


def _looks_like_a_port(spec: str) -> bool:
    return "/" in spec or "://" in spec or spec.upper().startswith("COM") or spec.startswith("\\")


LABGRID_PREFIX = "labgrid:"


def make_board(
    spec: str,
    options: BoardOptions | None = None,
    simavr: SimavrOptions | None = None,
    labgrid: LabgridOptions | None = None,
) -> Board:
    """The board SPEC names; `simavr` options only for a simavr board, `labgrid` ones
    only for a labgrid place."""
    if spec.startswith(LABGRID_PREFIX):
        from vehil.boards.labgrid import LabgridBoard  # labgrid (gRPC) loads only when used

        return LabgridBoard(spec[len(LABGRID_PREFIX) :], options, labgrid)
    if labgrid is not None:
        raise NoPort(f"labgrid options need a labgrid:PLACE board, not {spec!r}")
    cls = VIRTUAL_BOARDS.get(spec)
    if simavr is not None:
        if cls is None or not issubclass(cls, SimavrBoard):
            raise NoPort(f"simavr options (trace, gdb, profile) need a simavr board, not {spec!r}")
        return cls(options, simavr)
    if cls is not None:
        return cls(options)
    if not _looks_like_a_port(spec):
        raise NoPort(
            f"no board {spec!r}: give one of {', '.join(VIRTUAL_BOARDS)}, labgrid:PLACE, "
            f"or a serial port or pyserial URL (ports seen: {ports_seen()})"
        )
    return SerialBoard(spec, options)


def open_board(
    spec: str = DEFAULT_BOARD,
    options: BoardOptions | None = None,
    simavr: SimavrOptions | None = None,
    labgrid: LabgridOptions | None = None,
):  # noqa: ANN201
    return make_board(spec, options, simavr, labgrid).session()


__all__ = [
    "Board",
    "BoardOptions",
    "DEFAULT_BOARD",
    "LABGRID_PREFIX",
    "SimavrOptions",
    "VIRTUAL_BOARDS",
    "make_board",
    "open_board",
]
