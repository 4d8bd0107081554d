"""Boards: where the firmware runs, each reached through a pyserial URL.

`open_board(spec)` takes a name in VIRTUAL_BOARDS, or anything pyserial can
open (a device such as /dev/ttyACM0, or a URL such as socket://host:port), and
returns a context manager that starts the board, waits for its ready frame,
yields a Link with the board's INFO read, and stops the board on the way out,
on errors and Ctrl-C too.
"""

from __future__ import annotations

from vehil.boards.base import Board
from vehil.boards.native import NativeBoard
from vehil.boards.qemu import QemuBoard, QemuEvBoard
from vehil.boards.serialport import SerialBoard, ports_seen
from vehil.boards.simavr import (
    SimavrBoard,
    SimavrBootloaderBoard,
    SimavrEvBoard,
    SimavrMegaBoard,
    SimavrRealtimeBoard,
)
from vehil.errors import NoPort

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


def make_board(spec: str, **options: object) -> Board:
    if spec in VIRTUAL_BOARDS:
        return VIRTUAL_BOARDS[spec](**options)  # type: ignore[arg-type]
    if not _looks_like_a_port(spec):
        raise NoPort(
            f"no board {spec!r}: give one of {', '.join(VIRTUAL_BOARDS)}, or a serial port "
            f"or pyserial URL (ports seen: {ports_seen()})"
        )
    return SerialBoard(spec, **options)  # type: ignore[arg-type]


def open_board(spec: str = DEFAULT_BOARD, **options: object):  # noqa: ANN201
    return make_board(spec, **options).session()


__all__ = ["Board", "DEFAULT_BOARD", "VIRTUAL_BOARDS", "make_board", "open_board"]
