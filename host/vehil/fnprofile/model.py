"""A profile as the simavr bridge counted it (sim/profiler.c), named from the ELF:
per window (an estimator step, a frame, a cut of the run), the cycles of every calling
context; and over all windows, the cycles of every instruction."""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vehil.fnprofile.elfmap import VECTOR_NAMES, ElfMap, Function, Line


class ProfileError(AssertionError):
    """A profile assertion that failed (raised by Profile.assert_* for pytest)."""


@dataclass(frozen=True)
class FunctionStats:
    """One function over the windows: arrays with one value per window."""

    name: str
    library: str
    self: np.ndarray
    inclusive: np.ndarray
    calls: np.ndarray

    @property
    def label(self) -> str:
        return f"{self.name} [{self.library}]" if self.library else self.name


@dataclass(frozen=True)
class LineStats:
    line: Line | None
    function: str
    cycles: int  # all windows


@dataclass
class Profile:
    """What `vehil profile --functions` measured. Windows are in the order they ran: with
    the step window, window k is sample k's step."""

    what: str  # "step", "frame", "run"
    functions: list[Function]
    parent: np.ndarray  # per node
    func: np.ndarray  # per node: function index, len(functions) for none, -1 - v for vector v
    self_cycles: np.ndarray  # nodes x windows
    calls: np.ndarray  # nodes x windows
    how: list[str]  # per window: "end", "cut", "reset"
    pc_cycles: dict[int, int]  # byte address -> cycles, all windows
    elf: ElfMap | None = field(default=None, repr=False)
    per: int = 1  # exchanges (or steps) in one window
    idle: str | None = None  # the function whose own cycles are waiting, not work
    _stats: list[FunctionStats] | None = field(default=None, repr=False)

    # --- reading the bridge's file

    @classmethod
    def read(cls, path: Path, elf: ElfMap, what: str, segment: int = 0) -> Profile:
        """The bridge's output; `segment`: the part between two cuts (SIGUSR1) to keep."""
        nodes: dict[int, tuple[int, int]] = {}
        windows: list[tuple[str, dict[int, tuple[int, int]]]] = []
        pcs: dict[int, int] = {}
        current: dict[int, tuple[int, int]] | None = None
        part = 0
        for raw in path.read_text().splitlines():
            rec = raw.split()
            if not rec:
                continue
            if rec[0] == "N":
                nodes[int(rec[1])] = (int(rec[2]), int(rec[3]))
            elif rec[0] == "C":
                part += 1
            elif part != segment:
                continue
            elif rec[0] == "W":
                current = {}
                windows.append((rec[3], current))
            elif rec[0] == "S" and current is not None:
                current[int(rec[1])] = (int(rec[2]), int(rec[3]))
            elif rec[0] == "P":
                pcs[int(rec[1], 16)] = int(rec[2])
        n = max(nodes) + 1 if nodes else 0
        parent = np.full(n, -1, dtype=np.int64)
        func = np.zeros(n, dtype=np.int64)
        for i, (p, f) in nodes.items():
            parent[i], func[i] = p, f
        self_c = np.zeros((n, len(windows)), dtype=np.int64)
        calls = np.zeros((n, len(windows)), dtype=np.int64)
        for w, (_, counts) in enumerate(windows):
            for i, (c, k) in counts.items():
                self_c[i, w], calls[i, w] = c, k
        return cls(
            what, elf.functions, parent, func, self_c, calls, [h for h, _ in windows], pcs, elf
        )

    # --- names

    def node_name(self, i: int) -> str:
        f = int(self.func[i])
        if f < 0:
            v = -1 - f
            return f"interrupt {VECTOR_NAMES[v] if v < len(VECTOR_NAMES) else v}"
        return self.functions[f].label if f < len(self.functions) else "?"

    def stack(self, i: int) -> list[str]:
        out = []
        while i >= 0:
            out.append(self.node_name(i))
            i = int(self.parent[i])
        return out[::-1]

    # --- figures

    @property
    def windows(self) -> int:
        return self.self_cycles.shape[1]

    @property
    def window_cycles(self) -> np.ndarray:
        """Cycles counted in each window (every instruction in it, interrupts included)."""
        return self.self_cycles.sum(axis=0)

    def _in_interrupt(self) -> np.ndarray:
        """Per node: it runs in an interrupt (a vector node on its path)."""
        inside = np.zeros(len(self.func), dtype=bool)
        for i in range(len(self.func)):  # parents are created before their children
            p = int(self.parent[i])
            inside[i] = self.func[i] < 0 or (p >= 0 and inside[p])
        return inside

    @property
    def median_window(self) -> int:
        """The window whose counted cycles are the median: a typical step, as it ran."""
        order = np.argsort(self.window_cycles, kind="stable")
        return int(order[(len(order) - 1) // 2])

    @property
    def interrupt_cycles(self) -> np.ndarray:
        """Per window: cycles in interrupts that landed in it (RX/TX, Timer1 overflow)."""
        return self.self_cycles[self._in_interrupt()].sum(axis=0)

    def interrupts(self) -> dict[str, np.ndarray]:
        """Per interrupt vector: its cycles in each window."""
        inside = self._in_interrupt()
        out: dict[str, np.ndarray] = {}
        for i in np.flatnonzero(inside):
            j = int(i)
            while self.func[j] >= 0:
                j = int(self.parent[j])
            name = self.node_name(j)
            out[name] = out.get(name, 0) + self.self_cycles[i]
        return out

    def interrupt_entries(self) -> dict[str, np.ndarray]:
        """Per interrupt vector: how often it was entered in each window."""
        out: dict[str, np.ndarray] = {}
        for i in np.flatnonzero(self.func < 0):
            name = self.node_name(int(i))
            out[name] = out.get(name, 0) + self.calls[i]
        return out

    def function_stats(self) -> list[FunctionStats]:
        """Per function: self and inclusive cycles and calls in each window; hottest first.
        Inclusive counts a node once however often the function is on its path."""
        if self._stats is None:
            self._stats = self._function_stats()
        return self._stats

    def _function_stats(self) -> list[FunctionStats]:
        by_func: dict[int, list[int]] = defaultdict(list)
        paths: list[set[int]] = []
        for i in range(len(self.func)):
            p = int(self.parent[i])
            f = int(self.func[i])
            paths.append((paths[p] if p >= 0 else set()) | {f})
            by_func[f].append(i)
        incl: dict[int, np.ndarray] = defaultdict(lambda: np.zeros(self.windows, dtype=np.int64))
        for i, path in enumerate(paths):
            for f in path:
                incl[f] = incl[f] + self.self_cycles[i]
        out = []
        for f, nodes in by_func.items():
            if f < 0:
                continue
            fn = self.functions[f] if f < len(self.functions) else None
            out.append(
                FunctionStats(
                    fn.name if fn else "?",
                    fn.library if fn else "",
                    self.self_cycles[nodes].sum(axis=0),
                    incl[f],
                    self.calls[nodes].sum(axis=0),
                )
            )
        out.sort(key=lambda s: -int(s.self.sum()))
        return out

    def function(self, name: str) -> FunctionStats | None:
        """A function's figures by name (None if it never ran in a window)."""
        for s in self.function_stats():
            if s.name == name:
                return s
        return None

    def __contains__(self, name: str) -> bool:
        """`"__udivmoddi4" in profile`: the function ran in some window."""
        return self.function(name) is not None

    def collapsed(self, window: int | None = None) -> dict[str, int]:
        """Flame-graph stacks ("a;b;c" -> self cycles), summed over the windows (or of one)."""
        out: dict[str, int] = {}
        totals = self.self_cycles.sum(axis=1) if window is None else self.self_cycles[:, window]
        for i in np.flatnonzero(totals):
            out[";".join(self.stack(int(i)))] = int(totals[i])
        return out

    def hot_lines(self, n: int = 20) -> list[LineStats]:
        """The source lines whose instructions took the most cycles (all windows)."""
        assert self.elf is not None
        acc: dict[tuple[Line | None, str], int] = defaultdict(int)
        starts = [f.start for f in self.functions]
        import bisect

        for addr, c in self.pc_cycles.items():
            k = bisect.bisect_right(starts, addr) - 1
            fn = self.functions[k].label if k >= 0 else "?"
            line = self.elf.line_at(addr) if not (k >= 0 and self.functions[k].library) else None
            acc[(line, fn)] += c
        rows = [LineStats(ln, fn, c) for (ln, fn), c in acc.items()]
        rows.sort(key=lambda r: -r.cycles)
        return rows[:n]

    # --- for tests

    def assert_not_called(self, name: str) -> None:
        s = self.function(name)
        if s is not None:
            raise ProfileError(
                f"{name} ran in {int((s.calls > 0).sum())} of {self.windows} {self.what}s "
                f"(up to {int(s.calls.max())} calls, {int(s.inclusive.max())} cycles in one)"
            )

    def assert_self_at_most(self, name: str, cycles: int) -> None:
        s = self.function(name)
        worst = int(s.self.max()) if s is not None else 0
        if worst > cycles:
            raise ProfileError(
                f"{name}: {worst} self cycles in one {self.what}, more than {cycles} "
                f"(median {float(np.median(s.self)):.0f})"  # type: ignore[union-attr]
            )
