"""The scenario runner: a drive, sample by sample, through an estimator on a board.

Data flows one way: source (plant or log) -> float64 reference -> link -> board
-> recording. Two pacings:
- lockstep: as fast as the board answers, with the board's RX window kept full;
- real time: one sample per sample time by the host clock, stop-and-wait like an
  ECU's task; a result that comes back after the next sample is due is late.
Ctrl-C, a board that stops answering, or a link error end the run cleanly: the
recording keeps every sample up to that point and says how the run ended.
"""

from __future__ import annotations

import dataclasses
import re
import signal
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console
from rich.progress import BarColumn, Progress, ProgressColumn, Task, TextColumn, TimeRemainingColumn
from rich.text import Text

from vehil import plants, record
from vehil.boards import Board, BoardOptions, make_board, open_board
from vehil.errors import BoardError, BoardReset, BoardStartError, LinkError, VehilError
from vehil.link import BoardInfo, Link, Reply
from vehil.logs import trace_from_log
from vehil.paths import runs_dir
from vehil.plants.base import Trace
from vehil.scenario import Scenario, ScenarioError
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
    """A run's results; `ended` is completed, interrupted or failed (with `error`)."""

    prepared: Prepared
    board: str
    realtime: bool
    board_out: np.ndarray
    status: np.ndarray
    cycles: np.ndarray
    rtt_s: np.ndarray
    late: np.ndarray
    ended: str
    error: str | None
    wall_s: float
    info: dict[str, Any] = field(default_factory=dict)
    recording: Path | None = None
    native_out: np.ndarray | None = None  # FIXED with bit_exact: the native build's outputs
    resumes: list[Resume] = field(default_factory=list)  # board resets survived
    stack_bytes: int | None = None  # the board's stack high-water since boot, after the run
    expected: int | None = None  # samples the run was to have
    stop_signal: int | None = None  # the signal that interrupted it (SIGINT: Ctrl-C)

    @property
    def done(self) -> int:
        return len(self.board_out)


def prepare(scenario: Scenario) -> Prepared:
    spec = scenario.estimator
    if scenario.plant is not None:
        plant = plants.get(scenario.plant)
        trace = plant.run(
            scenario.plant_params, scenario.duration, scenario.sample_time, scenario.seed
        )
    else:
        assert scenario.log is not None
        trace = trace_from_log(scenario.log, spec, scenario.sample_time, scenario.duration)
    if spec.delay:
        # A windowed estimate is for the window's centre: compare it with the truth there.
        d = spec.delay
        trace.truth = {n: np.concatenate([v[:1].repeat(d), v[:-d]]) for n, v in trace.truth.items()}
    columns = []
    for s in spec.inputs:
        source = scenario.signals.get(s.name, s.name)
        if source not in trace.signals:
            raise ScenarioError(
                f"{scenario.path}: {spec.name} needs input {s.name!r} but the source gives "
                f"{', '.join(trace.signals)}; map it in [signals]"
            )
        x = np.asarray(trace.signals[source], dtype=np.float64)
        bad = np.flatnonzero(~np.isfinite(x))
        if len(bad):
            raise ScenarioError(
                f"{scenario.path}: input {s.name!r} is NaN/inf at sample {bad[0]} "
                f"(t = {trace.t[bad[0]]:g} s)"
            )
        columns.append(x)
    inputs = np.column_stack(columns) if columns else np.empty((len(trace), 0))
    ref = spec.reference(scenario.params)
    reference = np.array([ref.step(u) for u in inputs]).reshape(len(inputs), len(spec.outputs))
    return Prepared(scenario, trace, inputs, reference)


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


class _Drive:
    """An open-loop source: the whole drive and its reference are known before the run."""

    closed = False

    def __init__(self, prepared: Prepared):
        self.p = prepared
        self.total = len(prepared.inputs)

    def inputs(self, start: int = 0) -> Iterator[np.ndarray]:
        yield from self.p.inputs[start:]

    def after(self, k: int, out: np.ndarray) -> None:
        """Nothing acts back on a recorded or precomputed drive."""

    def row(self, k: int) -> tuple[float, np.ndarray, np.ndarray, dict[str, float]]:
        truth = {n: float(v[k]) for n, v in self.p.trace.truth.items()}
        return float(self.p.trace.t[k]), self.p.inputs[k], self.p.reference[k], truth

    def prepared(self) -> Prepared:
        return self.p


class _Loop:
    """A closed loop: the plant is stepped with the board's outputs. The float64 reference
    runs on the same measurements the board got, so their difference is numeric error
    alone, not two trajectories drifting apart."""

    closed = True

    def __init__(self, scenario: Scenario):
        self.sc = scenario
        spec = plants.get(scenario.plant or "")
        self.plant = spec.start_loop(scenario.plant_params, scenario.sample_time, scenario.seed)
        self.feedback = spec.feedback
        self.reference = scenario.estimator.reference(scenario.params)
        self.total = scenario.samples
        self.t: list[float] = []
        self.u: list[np.ndarray] = []
        self.ref: list[np.ndarray] = []
        self.truth: list[dict[str, float]] = []
        self.signals: list[dict[str, float]] = []
        self.outputs = [s.name for s in scenario.estimator.outputs]

    def inputs(self, start: int = 0) -> Iterator[np.ndarray]:
        """From sample `start`: ones measured already (sent, never answered) come again."""
        spec = self.sc.estimator
        yield from self.u[start:]
        for k in range(len(self.u), self.total):
            t, signals, truth = self.plant.measure()
            u = np.array([signals[self.sc.signals.get(s.name, s.name)] for s in spec.inputs])
            if not np.all(np.isfinite(u)):
                raise ScenarioError(f"{self.sc.path}: the plant measured NaN/inf at sample {k}")
            self.t.append(t)
            self.u.append(u)
            self.signals.append(signals)
            self.truth.append(truth)
            self.ref.append(np.asarray(self.reference.step(u), dtype=np.float64))
            yield u

    def after(self, k: int, out: np.ndarray) -> None:
        self.plant.apply({n: float(out[self.outputs.index(n)]) for n in self.feedback})

    def row(self, k: int) -> tuple[float, np.ndarray, np.ndarray, dict[str, float]]:
        return self.t[k], self.u[k], self.ref[k], self.truth[k]

    def prepared(self) -> Prepared:
        n = len(self.ref)
        names = self.truth[0].keys() if self.truth else ()
        trace = Trace(
            t=np.array(self.t[:n]),
            signals={k: np.array([s[k] for s in self.signals[:n]]) for k in self.signals[0]}
            if self.signals
            else {},
            truth={k: np.array([tr[k] for tr in self.truth[:n]]) for k in names},
        )
        m = len(self.outputs)
        inputs = np.array(self.u[:n]).reshape(n, len(self.sc.estimator.inputs))
        return Prepared(self.sc, trace, inputs, np.array(self.ref[:n]).reshape(n, m))


def _source(scenario: Scenario) -> _Drive | _Loop:
    return _Loop(scenario) if scenario.closed_loop else _Drive(prepare(scenario))


def _stream(
    link: Link,
    source: _Drive | _Loop,
    sc: Scenario,
    realtime: bool,
    window: int | None,
    start: int = 0,
) -> Iterator[tuple[int, Reply, bool, np.ndarray]]:
    """(k, reply, late, outputs) for each sample from `start`, in order. Lockstep open-loop
    runs keep the board's window full; real-time and closed-loop runs go one at a time."""
    spec, mode = sc.estimator, sc.mode
    frames = (spec.encode_inputs(u, mode) for u in source.inputs(start))
    if not realtime and not source.closed:
        requests = (("SAMPLE", {"inputs": body}) for body in frames)
        for k, reply in enumerate(link.pipeline(requests, window=window), start):
            yield k, reply, False, spec.decode_outputs(reply.fields()["outputs"], mode)
        return
    T = sc.sample_time
    t0 = time.perf_counter()
    for k, body in enumerate(frames, start):
        due = t0 + k * T
        while realtime and (wait := due - time.perf_counter()) > 0:
            time.sleep(min(wait, 0.002) if wait > 0.003 else 0)
        reply = link.request("SAMPLE", inputs=body)
        out = spec.decode_outputs(reply.fields()["outputs"], mode)
        source.after(k, out)
        yield k, reply, realtime and reply.sent_at + reply.rtt_s > due + T, out


@dataclass(frozen=True)
class Resume:
    """A board reset mid-run, and the run taken up again after it."""

    at_sample: int
    recovery_s: float
    reason: str


MAX_RESUMES = 3


def _configure(link: Link, sc: Scenario) -> None:
    spec = sc.estimator
    try:
        link.configure(spec.name, sc.mode, spec.encode_params(sc.params, sc.mode))
    except BoardError as exc:
        if exc.code != "BAD_PARAM" or not 0 <= exc.detail < len(spec.params):
            raise
        # The scenario range-checked every value, so the board refuses this one in this
        # numeric mode or together with the others: name it, and where the rules are.
        p = spec.params[exc.detail]
        raise BoardError(
            f"board refused CONFIG: BAD_PARAM (parameter {exc.detail}, {p.name} = "
            f"{sc.params[p.name]:g} {p.unit}, is in [{p.lo:g}, {p.hi:g}] but {spec.name} in "
            f"{sc.mode} refuses it with these parameters; what each mode takes: "
            f"firmware/lib/estimators/{spec.name}.h)",
            exc.code,
            exc.request,
            exc.detail,
        ) from None


def _catch_up(link: Link, source: _Drive | _Loop, sc: Scenario, answers: list[bytes]) -> None:
    """A board that rebooted gets the estimator configured again and every sample it had
    answered; each answer must repeat the one it gave before, bit for bit."""
    spec = sc.estimator
    link.hello()
    _configure(link, sc)
    frames = (spec.encode_inputs(source.row(k)[1], sc.mode) for k in range(len(answers)))
    replies = link.pipeline(("SAMPLE", {"inputs": body}) for body in frames)
    for k, (reply, before) in enumerate(zip(replies, answers, strict=True)):
        if reply.fields()["outputs"] != before:
            raise VehilError(
                f"the board rebooted and, given samples 0..{len(answers) - 1} again, answered "
                f"sample {k} differently: it cannot be resumed (non-deterministic estimator?)"
            )


def _on_link(
    link: Link,
    source: _Drive | _Loop,
    sc: Scenario,
    *,
    realtime: bool = False,
    window: int | None = None,
    on_sample: Callable[[int, Reply, bool, np.ndarray], None] | None = None,
    resumes: list[Resume] | None = None,
) -> None:
    """Streams the scenario. With `resumes`, a board reset in a lockstep run is survived:
    the board catches up from configuration (see _catch_up) and the run goes on."""
    _configure(link, sc)
    answers: list[bytes] = []  # each sample's outputs as on the wire
    while True:
        try:
            for k, reply, late, out in _stream(link, source, sc, realtime, window, len(answers)):
                answers.append(reply.fields()["outputs"])
                if on_sample is not None:
                    on_sample(k, reply, late, out)
            return
        except BoardReset as exc:
            if resumes is None or realtime or len(resumes) >= MAX_RESUMES:
                raise
            started = time.perf_counter()
            _catch_up(link, source, sc, answers)
            resumes.append(Resume(len(answers), time.perf_counter() - started, str(exc)))


def native_outputs(scenario: Scenario) -> np.ndarray:
    """The same scenario through the native build: the bits a FIXED board must match.
    A closed loop is deterministic too, so it is rerun whole."""
    outs: list[np.ndarray] = []
    with open_board("native") as link:
        _on_link(link, _source(scenario), scenario, on_sample=lambda k, r, late, o: outs.append(o))
    return np.array(outs).reshape(len(outs), len(scenario.estimator.outputs))


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
    source = _source(scenario)
    spec = scenario.estimator
    n_out = len(spec.outputs)
    options = BoardOptions(timeout_s=timeout_s)
    target = board if isinstance(board, Board) else make_board(board, options)
    board_name = board if isinstance(board, str) else target.name
    needs_native = scenario.mode == "FIXED" and any(
        t.bit_exact for t in scenario.tolerances.values()
    )
    native = native_outputs(scenario) if needs_native and board_name != "native" else None
    names = [s.name for s in spec.outputs]
    if source.closed:
        plant_truth = {s.name for s in plants.get(scenario.plant or "").truth}
        truth_names = [n for n in names if n in plant_truth]
    else:
        truth_names = list(source.prepared().truth())
    outs: list[np.ndarray] = []
    status: list[int] = []
    cycles: list[int] = []
    rtt: list[float] = []
    late: list[bool] = []
    resumes: list[Resume] = []
    stack_bytes: int | None = None
    ended, error, stop_signal = "completed", None, None
    recorder: record.Recorder | None = None
    info: dict[str, Any] = {}
    started = time.perf_counter()
    try:
        with target.session() as link:
            assert link.info is not None
            info = link.info.fields
            path = recording or default_recording_path(scenario, board_name)
            schema = record.columns([s.name for s in spec.inputs], names, truth_names)
            header = _header(scenario, board_name, realtime, link.info, source.total)
            recorder = record.Recorder(path, schema, header)
            with _progress(console) as progress:
                task = progress.add_task(
                    f"{scenario.name} on {board_name}", total=source.total, err=""
                )

                def on_sample(k: int, reply: Reply, is_late: bool, out: np.ndarray) -> None:
                    f = reply.fields()
                    outs.append(out)
                    status.append(f["status"])
                    cycles.append(f["cycles"])
                    rtt.append(reply.rtt_s)
                    late.append(is_late)
                    t, u, ref, truth = source.row(k)
                    row: dict[str, Any] = {
                        "k": k,
                        "t": t,
                        "status": f["status"],
                        "cycles": f["cycles"],
                        "rtt_s": reply.rtt_s,
                        "late": is_late,
                    }
                    for j, s in enumerate(spec.inputs):
                        row[f"in.{s.name}"] = float(u[j])
                    for j, n in enumerate(names):
                        row[f"ref.{n}"] = float(ref[j])
                        row[f"board.{n}"] = float(out[j])
                        if n in truth:
                            row[f"truth.{n}"] = truth[n]
                    assert recorder is not None
                    recorder.append(row)
                    if k % 64 == 0 or k == source.total - 1:
                        err = np.max(np.abs(out - ref)) if n_out else 0.0
                        progress.update(task, completed=k + 1, err=f"|board-ref| {err:.3g}")

                _on_link(
                    link,
                    source,
                    scenario,
                    realtime=realtime,
                    window=window,
                    on_sample=on_sample,
                    resumes=resumes,
                )
            stats = link.stats()
            if stats["stack_size"]:
                stack_bytes = stats["stack_size"] - stats["stack_unused"]
    except KeyboardInterrupt as exc:
        stop_signal = getattr(exc, "signum", signal.SIGINT)
        by = "Ctrl-C" if stop_signal == signal.SIGINT else signal.Signals(stop_signal).name
        ended, error = (
            "interrupted",
            f"stopped by {by} after {len(outs):,} of {source.total:,} samples",
        )
    except VehilError as exc:
        if recorder is None and isinstance(exc, BoardStartError):
            raise  # no board, no run: an error, not a failed run's report
        lost = "board lost after" if isinstance(exc, LinkError) else "after"
        ended, error = "failed", f"{lost} {len(outs):,} of {source.total:,} samples: {exc}"
    finally:
        wall = time.perf_counter() - started
        if recorder is not None:
            recorder.close(
                {
                    "ended": ended,
                    "error": error,
                    "wall_s": wall,
                    "resumes": [dataclasses.asdict(r) for r in resumes],
                    "stack_bytes": stack_bytes,
                    "signal": stop_signal,
                }
            )
    prepared = source.prepared()
    return Run(
        prepared=prepared,
        board=board_name,
        realtime=realtime,
        board_out=np.array(outs).reshape(len(outs), n_out),
        status=np.array(status, dtype=np.uint8),
        cycles=np.array(cycles, dtype=np.int64),
        rtt_s=np.array(rtt),
        late=np.array(late, dtype=bool),
        ended=ended,
        error=error,
        wall_s=wall,
        info=info,
        recording=recorder.path if recorder else None,
        native_out=native,
        resumes=resumes,
        stack_bytes=stack_bytes,
        expected=source.total,
        stop_signal=stop_signal,
    )
