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
from vehil.boards import Board, make_board, open_board
from vehil.errors import VehilError
from vehil.link import BoardInfo, Link, Reply
from vehil.logs import trace_from_log
from vehil.plants.base import Trace
from vehil.scenario import Scenario, ScenarioError


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


def _stream(
    link: Link,
    prepared: Prepared,
    realtime: bool,
    window: int | None,
) -> Iterator[tuple[int, Reply, bool]]:
    """(k, reply, late) for each sample, in order."""
    sc = prepared.scenario
    spec, mode = sc.estimator, sc.mode
    frames = (spec.encode_inputs(u, mode) for u in prepared.inputs)
    if not realtime:
        requests = (("SAMPLE", {"inputs": body}) for body in frames)
        for k, reply in enumerate(link.pipeline(requests, window=window)):
            yield k, reply, False
        return
    T = sc.sample_time
    start = time.perf_counter()
    for k, body in enumerate(frames):
        due = start + k * T
        while (wait := due - time.perf_counter()) > 0:
            time.sleep(min(wait, 0.002) if wait > 0.003 else 0)
        reply = link.request("SAMPLE", inputs=body)
        yield k, reply, reply.sent_at + reply.rtt_s > due + T


def _on_link(
    link: Link,
    prepared: Prepared,
    *,
    realtime: bool = False,
    window: int | None = None,
    on_sample: Callable[[int, Reply, bool, np.ndarray], None] | None = None,
) -> None:
    sc = prepared.scenario
    spec = sc.estimator
    link.configure(spec.name, sc.mode, spec.encode_params(sc.params, sc.mode))
    for k, reply, late in _stream(link, prepared, realtime, window):
        out = spec.decode_outputs(reply.fields()["outputs"], sc.mode)
        if on_sample is not None:
            on_sample(k, reply, late, out)


def native_outputs(prepared: Prepared) -> np.ndarray:
    """The same scenario through the native build: the bits a FIXED board must match."""
    outs: list[np.ndarray] = []
    with open_board("native") as link:
        _on_link(link, prepared, on_sample=lambda k, r, late, out: outs.append(out))
    return np.array(outs).reshape(len(outs), len(prepared.output_names))


def default_recording_path(scenario: Scenario, board: str, root: Path = Path("runs")) -> Path:
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    board_tag = board if board.isidentifier() else "port"
    return root / f"{scenario.name}-{board_tag}-{scenario.mode.lower()}-{stamp}" / "run.arrow"


def _header(prepared: Prepared, board: str, realtime: bool, info: BoardInfo) -> dict[str, Any]:
    sc, spec = prepared.scenario, prepared.scenario.estimator

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
    the returned Run says how it ended, and the recording holds what was done."""
    console = console or Console(stderr=True)
    prepared = prepare(scenario)
    spec = scenario.estimator
    n_out = len(spec.outputs)
    needs_native = scenario.mode == "FIXED" and any(
        t.bit_exact for t in scenario.tolerances.values()
    )
    target = board if isinstance(board, Board) else make_board(board, timeout_s=timeout_s)
    board_name = board if isinstance(board, str) else target.name
    native = native_outputs(prepared) if needs_native and board_name != "native" else None
    truth = prepared.truth()
    names = prepared.output_names
    outs: list[np.ndarray] = []
    status: list[int] = []
    cycles: list[int] = []
    rtt: list[float] = []
    late: list[bool] = []
    ended, error = "completed", None
    recorder: record.Recorder | None = None
    info: dict[str, Any] = {}
    started = time.perf_counter()
    try:
        with target.session() as link:
            assert link.info is not None
            info = link.info.fields
            path = recording or default_recording_path(scenario, board_name)
            schema = record.columns([s.name for s in spec.inputs], names, list(truth))
            header = _header(prepared, board_name, realtime, link.info)
            recorder = record.Recorder(path, schema, header)
            with _progress(console) as progress:
                task = progress.add_task(
                    f"{scenario.name} on {board_name}", total=len(prepared.inputs), err=""
                )

                def on_sample(k: int, reply: Reply, is_late: bool, out: np.ndarray) -> None:
                    f = reply.fields()
                    outs.append(out)
                    status.append(f["status"])
                    cycles.append(f["cycles"])
                    rtt.append(reply.rtt_s)
                    late.append(is_late)
                    row: dict[str, Any] = {
                        "k": k,
                        "t": float(prepared.trace.t[k]),
                        "status": f["status"],
                        "cycles": f["cycles"],
                        "rtt_s": reply.rtt_s,
                        "late": is_late,
                    }
                    for j, s in enumerate(spec.inputs):
                        row[f"in.{s.name}"] = float(prepared.inputs[k, j])
                    for j, n in enumerate(names):
                        row[f"ref.{n}"] = float(prepared.reference[k, j])
                        row[f"board.{n}"] = float(out[j])
                        if n in truth:
                            row[f"truth.{n}"] = float(truth[n][k])
                    assert recorder is not None
                    recorder.append(row)
                    if k % 64 == 0 or k == len(prepared.inputs) - 1:
                        err = np.max(np.abs(out - prepared.reference[k])) if n_out else 0.0
                        progress.update(task, completed=k + 1, err=f"|board-ref| {err:.3g}")

                _on_link(link, prepared, realtime=realtime, window=window, on_sample=on_sample)
    except KeyboardInterrupt:
        ended, error = "interrupted", f"stopped by Ctrl-C after {len(outs)} samples"
    except VehilError as exc:
        ended, error = "failed", f"after {len(outs)} samples: {exc}"
    finally:
        wall = time.perf_counter() - started
        if recorder is not None:
            recorder.close({"ended": ended, "error": error, "wall_s": wall})
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
    )
