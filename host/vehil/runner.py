"""The scenario runner: a drive, sample by sample, through an estimator on a board.

Data flows one way: source (plant or log, vehil.source) -> float64 reference -> link
-> board (vehil.session) -> recording and running metrics (Sink). Each piece holds a
chunk at a time, so a run's memory does not grow with its length. Ctrl-C, a board that
stops answering, or a link error end the run cleanly: the recording keeps every sample
up to that point and says how the run ended.
"""

from __future__ import annotations

import dataclasses
import functools
import re
import signal
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console
from rich.progress import BarColumn, Progress, ProgressColumn, Task, TextColumn, TimeRemainingColumn
from rich.text import Text

from vehil import compare, record, session, source
from vehil.boards import Board, BoardOptions, make_board, open_board
from vehil.errors import BoardStartError, LinkError, VehilError
from vehil.link import BoardInfo, Link, Reply
from vehil.paths import runs_dir
from vehil.plants.base import Trace
from vehil.scenario import Scenario
from vehil.session import Resume
from vehil.terminal import make_console


@dataclass
class Prepared:
    """Everything known before a board is involved: the drive and the reference's answer."""

    scenario: Scenario
    trace: Trace
    inputs: np.ndarray  # (N, n_inputs), float64, as the estimator's inputs
    reference: np.ndarray  # (N, n_outputs), float64

    def truth(self) -> dict[str, np.ndarray]:
        return {n: self.trace.truth[n] for n in self.output_names if n in self.trace.truth}

    @property
    def output_names(self) -> list[str]:
        return [s.name for s in self.scenario.estimator.outputs]


@dataclass
class Run:
    """A run: how it ended (completed, interrupted or failed, with `error`), its figures
    and verdict (computed as it went), and its recording. The per-sample arrays are read
    back from the recording when asked for (`board_out`, `cycles`...): a run never holds
    them itself."""

    scenario: Scenario
    board: str
    realtime: bool
    done: int  # samples answered
    figures: compare.Figures
    ended: str
    error: str | None
    wall_s: float
    recording: Path | None  # None: the board never answered, nothing was recorded
    info: dict[str, Any] = field(default_factory=dict)
    context: dict[str, Any] = field(default_factory=dict)  # the source's: a log's timing
    resumes: list[Resume] = field(default_factory=list)  # board resets survived
    stack_bytes: int | None = None  # the board's stack high-water since boot, after the run
    expected: int | None = None  # samples the run was to have
    stop_signal: int | None = None  # the signal that interrupted it (SIGINT: Ctrl-C)

    @functools.cached_property
    def recorded(self) -> record.Recording:
        if self.recording is None:
            raise VehilError(f"{self.scenario.name}: the run recorded nothing ({self.error})")
        return record.read(self.recording)

    @property
    def board_out(self) -> np.ndarray:
        return self.series.board

    @property
    def cycles(self) -> np.ndarray:
        return self.series.cycles

    @property
    def status(self) -> np.ndarray:
        return self.series.status

    @property
    def rtt_s(self) -> np.ndarray:
        return self.series.rtt_s

    @property
    def late(self) -> np.ndarray:
        return self.series.late

    @functools.cached_property
    def series(self) -> compare.Series:
        """The recording as a Series, built once for all the per-sample properties."""
        return compare.series_from_recording(self.recorded)

    @functools.cached_property
    def prepared(self) -> Prepared:
        """The drive and reference of the samples done: an open loop's made again whole
        (every plant signal and truth), a closed loop's as recorded."""
        if not self.scenario.closed_loop:
            p = prepare(self.scenario)
            n = self.done
            trace = Trace(
                t=p.trace.t[:n],
                signals={k: v[:n] for k, v in p.trace.signals.items()},
                truth={k: v[:n] for k, v in p.trace.truth.items()},
                units=p.trace.units,
            )
            return Prepared(self.scenario, trace, p.inputs[:n], p.reference[:n])
        d = self.recorded.data
        spec = self.scenario.estimator
        trace = Trace(
            t=d["t"],
            signals={c[6:]: v for c, v in d.items() if c.startswith("plant.")},
            truth={c[6:]: v for c, v in d.items() if c.startswith("truth.")},
        )
        n = len(d["t"])
        cols = [d[f"in.{s.name}"] for s in spec.inputs]
        inputs = np.column_stack(cols) if cols else np.empty((n, 0))
        reference = np.column_stack([d[f"ref.{s.name}"] for s in spec.outputs])
        return Prepared(self.scenario, trace, inputs, reference)


def prepare(scenario: Scenario) -> Prepared:
    """An open-loop scenario's whole drive (every signal and truth) and reference, held in
    memory: for analyses that want the arrays (a run streams them instead)."""
    drive = source.Drive(scenario, chunk=1 << 62)
    chunk = next(drive.chunks())
    assert chunk.trace is not None
    return Prepared(scenario, chunk.trace, chunk.inputs, chunk.reference)


class _RateColumn(ProgressColumn):
    def render(self, task: Task) -> Text:
        speed = task.finished_speed or task.speed
        return Text(f"{speed:,.0f} samples/s" if speed else "", style="cyan")


def _progress(console: Console) -> Progress:
    return Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        TextColumn("{task.completed:,}/{task.total:,}"),
        _RateColumn(),
        TimeRemainingColumn(),
        TextColumn("{task.fields[err]}"),
        console=console,
        transient=False,
    )


def native_mismatches(scenario: Scenario, recording: Path, samples: int) -> dict[str, int]:
    """Per output, how many of a recording's first `samples` board outputs differ in their
    bits from the native build's on the same scenario (a closed loop is rerun whole: it is
    deterministic too). Streams both: memory stays that of one batch."""
    names = [s.name for s in scenario.estimator.outputs]
    counts = dict.fromkeys(names, 0)
    recorded = (
        np.column_stack([c[f"board.{n}"] for n in names])
        for c in record.Reader(recording).columns()
    )
    batch, i = np.empty((0, len(names))), 0

    def compare(k: int, reply: Reply, late: bool, out: np.ndarray) -> None:
        nonlocal batch, i
        if i == len(batch):
            batch, i = next(recorded), 0
        for j, n in enumerate(names):
            counts[n] += int(out[j] != batch[i, j])
        i += 1

    with open_board("native") as link:
        session.drive(link, source.open_source(scenario, samples), scenario, on_sample=compare)
    return counts


def stack_used(link: Link) -> int | None:
    """The board's stack high-water since boot, read once the run's samples are all in
    (None: the board does not say). Faults injected on the link (`--faults`) are the run's:
    this read goes without them, so a run is not failed for a diagnostic its faults lost
    (at drop=1e-2 the STATS exchange fails 4 tries in 10). A board that has stopped
    answering, or rebooted, still fails it: LinkError."""
    disarm = getattr(link.port, "disarm", None)
    if disarm is not None:
        disarm()
    stats = link.stats()
    return stats["stack_size"] - stats["stack_unused"] if stats["stack_size"] else None


def _stopped_by(exc: KeyboardInterrupt) -> tuple[int, str]:
    """The signal that stopped a run (Ctrl-C's, or Terminated's), and its name for a user."""
    number = getattr(exc, "signum", signal.SIGINT)
    return number, "Ctrl-C" if number == signal.SIGINT else signal.Signals(number).name


def default_recording_path(scenario: Scenario, board: str, root: Path | None = None) -> Path:
    root = root or runs_dir()
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    board_tag = re.sub(r"[^\w.-]+", "-", board).strip("-") or "port"
    return root / f"{scenario.name}-{board_tag}-{scenario.mode.lower()}-{stamp}" / "run.arrow"


def _header(
    sc: Scenario, board: str, realtime: bool, info: BoardInfo, expected: int
) -> dict[str, Any]:
    spec = sc.estimator

    def signals(sigs: tuple) -> list[dict[str, Any]]:
        return [{"name": s.name, "unit": s.unit, "q": s.q} for s in sigs]

    return {
        "scenario": {
            "name": sc.name,
            "path": str(sc.path) if sc.path else None,
            "file": sc.raw,
            "params": sc.params,
            "mode": sc.mode,
            "sample_time": sc.sample_time,
            "closed_loop": sc.closed_loop,
            "score_from_s": sc.score_from_s,
            "expect_flags": list(sc.expect_flags),
        },
        "estimator": {
            "name": spec.name,
            "c_id": spec.c_id,
            "inputs": signals(spec.inputs),
            "outputs": signals(spec.outputs),
        },
        "tolerances": {n: vars(t) for n, t in sc.tolerances.items()},
        "board": {"name": board, "realtime": realtime, "info": info.fields},
        "firmware": {"version": info.firmware_version, "build_id": info.fields.get("build_id")},
        "expected_samples": expected,
        "started": datetime.now(UTC).isoformat(timespec="seconds"),
    }


class Sink:
    """Each answered sample into the recording, and from the recording's batches into the
    running metrics: what is judged is what was recorded."""

    def __init__(self, scenario: Scenario, src: source.Source, path: Path, header: dict[str, Any]):
        spec = scenario.estimator
        self.inputs = [s.name for s in spec.inputs]
        self.outputs = [s.name for s in spec.outputs]
        truth = src.plant_truth or src.truth_names
        units = {s.name: s.unit for s in (*spec.inputs, *spec.outputs)}
        self.metrics = compare.Metrics(
            self.outputs,
            units,
            dict(scenario.tolerances),
            src.truth_names,
            scenario.score_from_s,
            scenario.expect_flags,
        )
        schema = record.columns(self.inputs, self.outputs, truth, src.plant_signals)
        self.recorder = record.Recorder(path, schema, header, self.metrics.add_columns)
        self.source = src

    def sample(self, k: int, reply: Reply, late: bool, out: np.ndarray) -> None:
        f = reply.fields()
        chunk, i = self.source.at(k)
        row: dict[str, Any] = {
            "k": k,
            "t": float(chunk.t[i]),
            "status": f["status"],
            "cycles": f["cycles"],
            "rtt_s": reply.rtt_s,
            "late": late,
        }
        for j, n in enumerate(self.inputs):
            row[f"in.{n}"] = float(chunk.inputs[i, j])
        for j, n in enumerate(self.outputs):
            row[f"ref.{n}"] = float(chunk.reference[i, j])
            row[f"board.{n}"] = float(out[j])
        for n, v in chunk.truth.items():
            row[f"truth.{n}"] = float(v[i])
        if self.source.plant_signals and chunk.trace is not None:
            for n in self.source.plant_signals:
                row[f"plant.{n}"] = float(chunk.trace.signals[n][i])
        self.recorder.append(row)

    def history(self, answered: int) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        """The first `answered` samples' inputs and board outputs, read back from the file."""
        self.recorder.flush()
        left = answered
        for c in record.Reader(self.recorder.path).columns():
            take = min(left, len(c["k"]))
            cols = [c[f"in.{n}"][:take] for n in self.inputs]
            ins = np.column_stack(cols) if cols else np.empty((take, 0))
            outs = np.column_stack([c[f"board.{n}"][:take] for n in self.outputs])
            yield ins, outs
            left -= take
            if not left:
                return


def run(
    scenario: Scenario,
    board: str | Board = "simavr",
    *,
    realtime: bool = False,
    window: int | None = None,
    recording: Path | None = None,
    console: Console | None = None,
    timeout_s: float = 2.0,
) -> Run:
    """Runs a scenario on a board and records it. Never raises for a run that started:
    the returned Run says how it ended, and the recording holds what was done. A board
    that cannot be started raises BoardStartError: there was no run."""
    console = console or make_console(stderr=True)
    record.load_conversions()
    src = source.open_source(scenario)
    options = BoardOptions(timeout_s=timeout_s)
    target = board if isinstance(board, Board) else make_board(board, options)
    board_name = board if isinstance(board, str) else target.name
    path = recording or default_recording_path(scenario, board_name)
    path.parent.mkdir(parents=True, exist_ok=True)  # before the board starts: nothing to stop
    resumes: list[Resume] = []
    stack_bytes: int | None = None
    ended, error, stop_signal = "completed", None, None
    sink: Sink | None = None
    info: dict[str, Any] = {}
    done = 0
    started = time.perf_counter()
    try:
        with target.session() as link:
            assert link.info is not None
            info = link.info.fields
            header = _header(scenario, board_name, realtime, link.info, src.total)
            sink = Sink(scenario, src, path, header)
            with _progress(console) as progress:
                task = progress.add_task(
                    f"{scenario.name} on {board_name}", total=src.total, err=""
                )

                def on_sample(k: int, reply: Reply, late: bool, out: np.ndarray) -> None:
                    nonlocal done
                    assert sink is not None
                    sink.sample(k, reply, late, out)
                    done = k + 1
                    if k % 64 == 0 or k == src.total - 1:
                        chunk, i = src.at(k)
                        err = np.max(np.abs(out - chunk.reference[i])) if len(out) else 0.0
                        progress.update(task, completed=k + 1, err=f"|board-ref| {err:.3g}")

                session.drive(
                    link,
                    src,
                    scenario,
                    realtime=realtime,
                    window=window,
                    on_sample=on_sample,
                    history=sink.history,
                    resumes=resumes,
                )
            stack_bytes = stack_used(link)
    except KeyboardInterrupt as exc:
        stop_signal, by = _stopped_by(exc)
        ended, error = "interrupted", f"stopped by {by} after {done:,} of {src.total:,} samples"
    except VehilError as exc:
        if sink is None and isinstance(exc, BoardStartError):
            raise  # no board, no run: an error, not a failed run's report
        if isinstance(exc, LinkError) and sink is not None and done == src.total:
            # every sample answered, then the read of the board's stack was not
            error = f"board lost after its last sample (all {done:,} answered): {exc}"
        else:
            lost = "board lost after" if isinstance(exc, LinkError) else "after"
            error = f"{lost} {done:,} of {src.total:,} samples: {exc}"
        ended = "failed"
    finally:
        wall = time.perf_counter() - started
        if sink is not None:
            sink.recorder.close(
                {
                    "ended": ended,
                    "error": error,
                    "wall_s": wall,
                    "resumes": [dataclasses.asdict(r) for r in resumes],
                    "stack_bytes": stack_bytes,
                    "signal": stop_signal,
                }
            )
    if sink is None:  # the board never came up: no recording, nothing judged
        metrics = compare.Metrics(
            [s.name for s in scenario.estimator.outputs], {}, dict(scenario.tolerances), []
        )
    else:
        metrics = sink.metrics
    needs_native = scenario.mode == "FIXED" and any(
        t.bit_exact for t in scenario.tolerances.values()
    )
    mismatches = None
    if needs_native and board_name != "native" and done:
        try:
            mismatches = native_mismatches(scenario, path, done)
        except KeyboardInterrupt as exc:  # the samples are in: judge them, bits unchecked
            stop_signal, by = _stopped_by(exc)
            if ended == "completed":
                ended = "interrupted"
                error = (
                    f"stopped by {by} while the board's bits were checked against the "
                    f"native build, after all {done:,} samples: bits not checked"
                )
    figures = metrics.figures(
        ended=ended,
        error=error,
        expected=src.total,
        stop_signal=stop_signal,
        stack_bytes=stack_bytes,
        native_board=board_name == "native",
        mismatches=mismatches,
    )
    return Run(
        scenario=scenario,
        board=board_name,
        realtime=realtime,
        done=done,
        figures=figures,
        ended=ended,
        error=error,
        wall_s=wall,
        recording=path if sink is not None else None,
        info=info,
        context=src.context,
        resumes=resumes,
        stack_bytes=stack_bytes,
        expected=src.total,
        stop_signal=stop_signal,
    )
