"""Where a run's samples come from: a plant or a log, with the float64 reference beside.

A source hands the session the estimator's inputs one sample at a time and keeps each
sample's time, reference and truth until the recorder has taken it, then lets it go:
an open-loop drive is made in chunks (a plant that can stream makes each chunk on its
own; one that computes its drive whole, and a log, is sliced), so a run holds a few
chunks, not the drive, whatever its length. A closed loop is stepped with the board's
outputs, one sample at a time.
"""

from __future__ import annotations

import itertools
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from vehil import plants
from vehil.logs import trace_from_log
from vehil.plants.base import Trace
from vehil.scenario import Scenario, ScenarioError

CHUNK = 4096  # samples made at a time


@dataclass
class Chunk:
    """Samples k0 .. k0 + len(t) - 1: time, estimator inputs, reference, truth by output."""

    k0: int
    t: np.ndarray
    inputs: np.ndarray  # (n, n_inputs) float64
    reference: np.ndarray  # (n, n_outputs) float64
    truth: dict[str, np.ndarray]  # the outputs'
    trace: Trace | None = None  # open loop: the piece of the drive, every signal and truth

    @property
    def end(self) -> int:
        return self.k0 + len(self.t)


class Source:
    """Chunks made on demand, kept from the oldest sample not yet recorded on."""

    closed = False

    def __init__(self, scenario: Scenario, total: int, truth_names: list[str]):
        self.sc = scenario
        self.total = total
        self.truth_names = truth_names  # outputs with a truth to compare with
        self.plant_truth: list[str] = []  # closed loop: every truth the plant gives, recorded
        self.plant_signals: list[str] = []  # closed loop: every signal it measures, recorded
        self.context: dict[str, Any] = {}  # what a report says about the source (log timing)
        self._kept: deque[Chunk] = deque()
        self._made = 0  # samples made so far
        self._chunks: Iterator[Chunk] = iter(())

    def _next_chunk(self) -> Chunk | None:
        chunk = next(self._chunks, None)
        if chunk is not None:
            self._kept.append(chunk)
            self._made = chunk.end
        return chunk

    def chunks(self) -> Iterator[Chunk]:
        """The chunks not made yet, in order, without keeping them."""
        return self._chunks

    def inputs(self, start: int = 0) -> Iterator[np.ndarray]:
        """From sample `start` (kept, or made from here on): after a board reset, the
        samples sent but never answered come again."""
        for kept in list(self._kept):
            yield from kept.inputs[max(start - kept.k0, 0) : self.total - kept.k0]
        while self._made < self.total and (chunk := self._next_chunk()) is not None:
            yield from chunk.inputs[: self.total - chunk.k0]

    def after(self, k: int, out: np.ndarray) -> None:
        """Nothing acts back on an open-loop drive."""

    def at(self, k: int) -> tuple[Chunk, int]:
        """The chunk holding sample k, and k's place in it; earlier samples are let go."""
        while self._kept and self._kept[0].end <= k:
            self._kept.popleft()
        return self._kept[0], k - self._kept[0].k0


class Drive(Source):
    """An open loop: a plant's drive or a log, in chunks, with the reference run over it."""

    def __init__(self, scenario: Scenario, limit: int | None = None, chunk: int = CHUNK):
        pieces = _traces(scenario, chunk)
        first = next(pieces, None)
        if first is None:
            raise ScenarioError(f"{scenario.path}: the source gives no samples")
        total = first.total if limit is None else min(first.total, limit)
        outputs = [s.name for s in scenario.estimator.outputs]
        super().__init__(scenario, total, [n for n in outputs if n in first.trace.truth])
        self.context = {
            "log_inputs": getattr(first.trace, "timing", None),
            "log_notes": getattr(first.trace, "notes", None),
        }
        self._chunks = _chunks(scenario, first, pieces)


@dataclass
class _Piece:
    trace: Trace
    total: int  # samples in the whole drive


def _traces(scenario: Scenario, chunk: int) -> Iterator[_Piece]:
    spec = scenario.estimator
    if scenario.plant is not None:
        plant = plants.get(scenario.plant)
        args = (scenario.plant_params, scenario.duration, scenario.sample_time, scenario.seed)
        if plant.stream is not None:
            for trace in plant.run_chunks(*args, chunk):
                yield _Piece(trace, scenario.samples)
            return
        whole = plant.run(*args)
    else:
        assert scenario.log is not None
        whole = trace_from_log(scenario.log, spec, scenario.sample_time, scenario.duration)
    # Made whole (a plant's physical drive, a log read in): sliced, so what follows
    # works on chunks alike and lets each go once it is recorded.
    for k0 in range(0, len(whole), chunk):
        piece = Trace(
            t=whole.t[k0 : k0 + chunk],
            signals={n: v[k0 : k0 + chunk] for n, v in whole.signals.items()},
            truth={n: v[k0 : k0 + chunk] for n, v in whole.truth.items()},
            units=whole.units,
        )
        for attr in ("timing", "notes"):
            if hasattr(whole, attr):
                setattr(piece, attr, getattr(whole, attr))
        yield _Piece(piece, len(whole))


def _chunks(scenario: Scenario, first: _Piece, rest: Iterator[_Piece]) -> Iterator[Chunk]:
    """Each piece as the estimator's inputs, its reference and its truth."""
    spec = scenario.estimator
    ref = spec.reference(scenario.params)
    outputs = [s.name for s in spec.outputs]
    d = spec.delay
    carry: dict[str, np.ndarray] = {}  # a windowed estimate's truth: the last d values
    k0 = 0
    for piece in itertools.chain([first], rest):
        trace = piece.trace
        if d:
            # A windowed estimate is for the window's centre: compare it with the truth there.
            for name, v in trace.truth.items():
                joined = np.concatenate([carry.get(name, v[:1].repeat(d)), v])
                trace.truth[name], carry[name] = joined[: len(v)], joined[-d:]
        truth = {name: v for name, v in trace.truth.items() if name in outputs}
        columns = []
        for s in spec.inputs:
            name = scenario.signals.get(s.name, s.name)
            if name not in trace.signals:
                raise ScenarioError(
                    f"{scenario.path}: {spec.name} needs input {s.name!r} but the source gives "
                    f"{', '.join(trace.signals)}; map it in [signals]"
                )
            x = np.asarray(trace.signals[name], dtype=np.float64)
            bad = np.flatnonzero(~np.isfinite(x))
            if len(bad):
                raise ScenarioError(
                    f"{scenario.path}: input {s.name!r} is NaN/inf at sample {k0 + bad[0]} "
                    f"(t = {trace.t[bad[0]]:g} s)"
                )
            columns.append(x)
        n = len(trace)
        inputs = np.column_stack(columns) if columns else np.empty((n, 0))
        reference = np.array([ref.step(u) for u in inputs]).reshape(n, len(outputs))
        yield Chunk(k0, np.asarray(trace.t, dtype=np.float64), inputs, reference, truth, trace)
        k0 += n


class Loop(Source):
    """A closed loop: the plant is stepped with the board's outputs. The float64 reference
    runs on the same measurements the board got, so their difference is numeric error
    alone, not two trajectories drifting apart."""

    closed = True

    def __init__(self, scenario: Scenario, limit: int | None = None):
        spec = plants.get(scenario.plant or "")
        outputs = [s.name for s in scenario.estimator.outputs]
        plant_truth = {s.name for s in spec.truth}
        total = scenario.samples if limit is None else min(scenario.samples, limit)
        super().__init__(scenario, total, [n for n in outputs if n in plant_truth])
        self.plant = spec.start_loop(scenario.plant_params, scenario.sample_time, scenario.seed)
        self.feedback = spec.feedback
        self.reference = scenario.estimator.reference(scenario.params)
        self.outputs = outputs
        self.plant_truth = [s.name for s in spec.truth]
        self.plant_signals = [s.name for s in spec.signals]
        self._chunks = self._steps()

    def _steps(self) -> Iterator[Chunk]:
        """One sample at a time, measured only when asked for: after the last one's output
        was applied."""
        sc = self.sc
        names = [sc.signals.get(s.name, s.name) for s in sc.estimator.inputs]
        for k in range(self.total):
            t, signals, truth = self.plant.measure()
            u = np.array([signals[n] for n in names], dtype=np.float64)
            if not np.all(np.isfinite(u)):
                raise ScenarioError(f"{sc.path}: the plant measured NaN/inf at sample {k}")
            ref = np.asarray(self.reference.step(u), dtype=np.float64)
            tt = np.array([t])
            truths = {n: np.array([truth[n]]) for n in self.plant_truth}
            measured = {n: np.array([signals[n]]) for n in self.plant_signals}
            yield Chunk(
                k, tt, u.reshape(1, -1), ref.reshape(1, -1), truths, Trace(tt, measured, truths)
            )

    def after(self, k: int, out: np.ndarray) -> None:
        self.plant.apply({n: float(out[self.outputs.index(n)]) for n in self.feedback})


def open_source(scenario: Scenario, limit: int | None = None) -> Source:
    """The scenario's source; `limit` stops it after that many samples."""
    return Loop(scenario, limit) if scenario.closed_loop else Drive(scenario, limit)
