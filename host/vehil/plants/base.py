"""A plant is the ground truth: it simulates a vehicle and its sensors.

An open-loop plant returns a drive (seeded): the time base, the measured signals an
estimator takes as inputs, and the true values of what estimators estimate. Most plants
also `stream` it, chunk by chunk with the same samples, so a run of any length holds a
few chunks; one that does not (braking: its sensor model filters the whole drive) is
made whole and sliced. Names are the estimators' signal names, so
the runner wires plant to estimator by name (a scenario can rename).

A plant that can also close the loop gives a `loop` factory: a LoopPlant the
runner steps one sample at a time, applying the board's outputs named in
`feedback` (an actuator force, say) before the next sample.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from vehil import units
from vehil.csvlog import LogError, read_csv
from vehil.spec import Param, Signal, resolve_params


@dataclass
class Trace:
    """A drive, sampled at the estimator's rate: t[k] and each signal's value at t[k]."""

    t: np.ndarray
    signals: dict[str, np.ndarray]
    truth: dict[str, np.ndarray]
    units: dict[str, str] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.t)


class LoopPlant(Protocol):
    """A plant in a closed loop, one sample time per apply()."""

    def measure(self) -> tuple[float, dict[str, float], dict[str, float]]:
        """t, the measured signals and the true values at the current sample."""
        ...

    def apply(self, outputs: Mapping[str, float]) -> None:
        """Acts on the estimator's outputs for this sample, then advances one sample time."""
        ...


@dataclass(frozen=True)
class FileInput:
    """A table a plant can take from a CSV (`name [unit]` header) instead of making it:
    a recorded road, a GPS trace. `columns` are the ones it needs, with their units."""

    name: str
    columns: tuple[Signal, ...]
    doc: str = ""

    def load(self, path: Path) -> dict[str, np.ndarray]:
        table = read_csv(path)
        out = {}
        for col in self.columns:
            if col.name not in table.values:
                raise LogError(
                    f"{path}: no column {col.name!r} ({self.name} needs "
                    f"{', '.join(f'{c.name} [{c.unit}]' for c in self.columns)})"
                )
            x, have = table.values[col.name], table.units[col.name]
            if have != col.unit:
                try:
                    x = units.convert(x, have, col.unit)  # km/h, ft: to what the plant takes
                except units.UnitError as exc:
                    what = f"is in {have!r}" if have else "has no unit"
                    raise LogError(
                        f"{path}: column {col.name!r} {what}; {self.name} needs {col.unit!r}"
                        + (f" ({exc})" if have else f": write `{col.name} [{col.unit}]`")
                    ) from None
            if not np.all(np.isfinite(x)):
                raise LogError(f"{path}: column {col.name!r} has NaN/inf on line {_first_bad(x)}")
            out[col.name] = x
        t = out.get("t")
        if t is not None and (len(t) < 2 or np.any(np.diff(t) <= 0)):
            raise LogError(f"{path}: column 't' must rise strictly, over at least two rows")
        return out


def _first_bad(x: np.ndarray) -> int:
    return int(np.flatnonzero(~np.isfinite(x))[0]) + 2  # the header is line 1


@dataclass(frozen=True)
class PlantSpec:
    name: str
    title: str
    params: tuple[Param, ...]
    signals: tuple[Signal, ...]  # measured: what an estimator may take as input
    truth: tuple[Signal, ...]  # true values an estimator's outputs are compared with
    simulate: Callable[[Mapping[str, Any], float, float, int], Trace]
    doc: str = ""
    loop: Callable[[Mapping[str, Any], float, int], LoopPlant] | None = None  # (params, T, seed)
    feedback: tuple[str, ...] = ()  # estimator outputs the loop plant acts on
    files: tuple[FileInput, ...] = ()  # tables it can read instead of making them
    # (params, duration, T, seed, chunk): the same drive as `simulate`, chunk by chunk, so
    # a long one is never held whole
    stream: Callable[[Mapping[str, Any], float, float, int, int], Iterator[Trace]] | None = None

    def param_values(self, given: Mapping[str, Any]) -> dict[str, Any]:
        """Numbers with their defaults, and each file input loaded (None if not given)."""
        files = {f.name: f for f in self.files}
        values: dict[str, Any] = resolve_params(
            f"plant {self.name}", self.params, {k: v for k, v in given.items() if k not in files}
        )
        for name, f in files.items():
            v = given.get(name)  # a path, or a table loaded already
            values[name] = f.load(Path(v)) if isinstance(v, (str, Path)) else v
        return values

    def start_loop(self, params: Mapping[str, Any], T: float, seed: int) -> LoopPlant:
        if self.loop is None:
            raise ValueError(f"plant {self.name} cannot close a loop")
        return self.loop(self.param_values(params), T, seed)

    def run(self, params: Mapping[str, Any], duration: float, T: float, seed: int) -> Trace:
        trace = self.simulate(self.param_values(params), duration, T, seed)
        trace.units = {s.name: s.unit for s in (*self.signals, *self.truth)}
        return trace

    def run_chunks(
        self, params: Mapping[str, Any], duration: float, T: float, seed: int, chunk: int
    ) -> Iterator[Trace]:
        """The drive `run` gives, `chunk` samples at a time (a plant with `stream`)."""
        assert self.stream is not None
        units = {s.name: s.unit for s in (*self.signals, *self.truth)}
        for trace in self.stream(self.param_values(params), duration, T, seed, chunk):
            trace.units = units
            yield trace


def joined(
    stream: Callable[[Mapping[str, Any], float, float, int, int], Iterator[Trace]],
) -> Callable[[Mapping[str, Any], float, float, int], Trace]:
    """A streaming plant's whole drive: its chunks end to end."""

    def simulate(p: Mapping[str, Any], duration: float, T: float, seed: int) -> Trace:
        return join(stream(p, duration, T, seed, 1 << 16))

    return simulate


def join(pieces: Iterable[Trace]) -> Trace:
    """Chunks of a drive end to end."""
    got = list(pieces)
    return Trace(
        t=np.concatenate([x.t for x in got]),
        signals={n: np.concatenate([x.signals[n] for x in got]) for n in got[0].signals},
        truth={n: np.concatenate([x.truth[n] for x in got]) for n in got[0].truth},
    )


def chunk_times(n: int, T: float, chunk: int) -> Iterator[np.ndarray]:
    """The sample times of an n-sample drive, `chunk` at a time."""
    for k0 in range(0, n, chunk):
        yield np.arange(k0, min(n, k0 + chunk)) * T


class NoiseBlocks:
    """White noise a plant draws for the whole drive, one signal's block after another from
    one generator, handed out a chunk at a time with the very same values: a copy of the
    generator is set at each block's start by drawing (and dropping) the blocks before it.
    Memory is a chunk's; the cost is one more pass of draws. The generator is left after
    the last block, as drawing them whole would leave it."""

    def __init__(self, rng: np.random.Generator, n: int, blocks: int):
        self._at = []
        for _ in range(blocks):
            self._at.append(copy.deepcopy(rng))
            for k0 in range(0, n, 1 << 16):
                rng.standard_normal(min(1 << 16, n - k0))

    def normal(self, block: int, scale: float, m: int) -> np.ndarray:
        """The block's next m values, N(0, scale²)."""
        return self._at[block].normal(0.0, scale, m)
