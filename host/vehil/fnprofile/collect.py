"""Profiled runs on simavr: the bridge counts, the ELF names, a Profile comes back.

Windows: "step" (every estimator step: the message core's call of the step, with
everything it calls and every interrupt that lands in it), "frame" (the message core's
handling of each complete frame: dispatch, reply encoded and queued), "exchange" (the
whole firmware between two cuts, for N PING exchanges: RX and TX interrupts, bytes
into the frame buffer, the frame path) and "run" (the whole firmware, the whole run)."""

from __future__ import annotations

import os
import signal
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rich.console import Console

from vehil.boards import VIRTUAL_BOARDS, Board, BoardOptions, SimavrOptions, make_board
from vehil.boards.simavr import SimavrBoard, SimavrBootloaderBoard
from vehil.errors import VehilError
from vehil.fnprofile.elfmap import ElfMap, instruction_words
from vehil.fnprofile.model import Profile

# A frame's handling, from one code mark to the other (firmware/lib/board/dispatch.c):
# inlined, its code is interleaved with the receive loop's.
FRAME_MARKS = ("vehil_frame_begin", "vehil_frame_end")
IDLE_FUNCTION = "uart_rx_wait"  # firmware/src/uart.c: the main loop's wait for bytes


def _profilable(cls: type[Board]) -> bool:
    """A board whose firmware runs on the simavr bridge from an ELF (not the bootloader)."""
    return issubclass(cls, SimavrBoard) and not issubclass(cls, SimavrBootloaderBoard)


def _board_class(name: str) -> type[SimavrBoard]:
    cls = VIRTUAL_BOARDS.get(name)
    if cls is None or not _profilable(cls):
        raise VehilError(
            f"profiling by function counts cycles in the simavr bridge: board {name!r} cannot; "
            f"use one of {', '.join(n for n, c in VIRTUAL_BOARDS.items() if _profilable(c))}"
        )
    return cls  # type: ignore[return-value]


def elf_of(board: str) -> Path:
    """The image the board runs."""
    return _board_class(board)().elf


def _ranges(ranges: list[tuple[int, int]]) -> str:
    return ",".join(f"{lo:x}-{hi:x}" for lo, hi in ranges)


@dataclass
class Session:
    """The bridge's options for one profiled board, and where its output lands."""

    elf: ElfMap
    what: str
    folder: Path

    @property
    def output(self) -> Path:
        return self.folder / "profile.txt"

    def bridge_args(self) -> list[str]:
        self.folder.mkdir(parents=True, exist_ok=True)
        fmap = self.folder / "functions.map"
        fmap.write_text(self.elf.map_text())
        args = ["--profile", str(self.output), "--profile-map", str(fmap)]
        if self.what not in ("step", "frame", "exchange", "run"):
            raise VehilError(f"no profile window {self.what!r}: step, frame, exchange or run")
        if self.what == "step":
            sites = self.elf.step_call_sites()
            ranges = [(a, a + 2 * instruction_words(self.elf.word(a))) for a in sites]
        elif self.what == "frame":
            begin, end = (self.elf.mark(name) for name in FRAME_MARKS)
            args += ["--profile-window-end", _ranges([end])]
            ranges = [begin]
        else:
            ranges = []
        if ranges:
            args += ["--profile-window", _ranges(ranges)]
        return args

    def board(self, name: str, options: BoardOptions | None = None) -> Board:
        return make_board(name, options, SimavrOptions(profile=tuple(self.bridge_args())))

    def read(self) -> Profile:
        if not self.output.exists():
            raise VehilError(f"the simavr bridge wrote no profile ({self.output})")
        return Profile.read(self.output, self.elf, self.what)


def session(board: str, what: str, folder: Path | None = None) -> Session:
    path = elf_of(board)
    folder = folder or Path(tempfile.mkdtemp(prefix="vehil-profile-"))
    return Session(ElfMap(path), what, folder)


@dataclass
class ProfiledRun:
    run: Any  # runner.Run
    profile: Profile


def scenario_steps(
    sc: Any,  # scenario.Scenario
    board: str = "simavr",
    *,
    window: int | None = None,
    folder: Path | None = None,
    console: Console | None = None,
    timeout_s: float = 2.0,
    per: str = "step",
) -> ProfiledRun:
    """Runs a scenario with every step profiled (`per` "frame": every frame the core
    handles; "run": the whole run, boot included, one window); window 1 is
    stop-and-wait (no receive interrupt lands in a step), None keeps the board's RX
    window full (lockstep)."""
    from vehil import runner

    s = session(board, per, folder)
    target = s.board(board, BoardOptions(timeout_s=timeout_s))
    rec = s.folder / "run.arrow"
    run = runner.run(
        sc,
        target,
        window=window,
        recording=rec,
        console=console or Console(quiet=True),
        timeout_s=timeout_s,
    )
    if run.error:
        raise VehilError(f"the profiled run of {sc.name} failed: {run.error}")
    profile = s.read()
    if per == "run":
        profile.idle = IDLE_FUNCTION
    return ProfiledRun(run, profile)


def _cut(board: Board) -> None:
    """SIGUSR1: the bridge closes the run's window here and opens the next."""
    assert isinstance(board, SimavrBoard) and board.process is not None
    os.kill(board.process.proc.pid, signal.SIGUSR1)
    time.sleep(0.05)


def pings(
    board: str = "simavr",
    *,
    size: int = 16,
    count: int = 100,
    what: str = "frame",
    folder: Path | None = None,
    timeout_s: float = 2.0,
    window: int = 1,
    baud: int | None = None,
) -> Profile:
    """PING exchanges profiled, `window` in flight (1: stop-and-wait) at `baud` (None:
    the board's): "frame" has one window per frame the core handled; "exchange" one
    window over all `count` exchanges, the whole firmware."""
    from vehil.ping import run_ping

    s = session(board, what, folder)
    target = s.board(board, BoardOptions(timeout_s=timeout_s))
    with target.session() as link:
        if baud is not None:
            link.set_baud(baud)
        run_ping(link, count=3, size=size)
        _cut(target)  # what the boot and the warm-up did is segment 0
        run_ping(link, count=count, size=size, window=window)
        _cut(target)
    profile = Profile.read(s.output, s.elf, what, segment=1)
    if what == "exchange":
        profile.per = count
        profile.idle = IDLE_FUNCTION
    elif profile.windows != count:
        raise VehilError(
            f"{count} PINGs gave {profile.windows} frame windows: the frame path's code "
            f"(between {' and '.join(FRAME_MARKS)}) is not one stretch the window can follow "
            "in this image"
        )
    return profile
