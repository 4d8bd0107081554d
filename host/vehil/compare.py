"""Metrics and the verdict: how far the board is from the float64 reference and from the
truth, whether its bits are the native build's, and what the run as a whole comes to.

One evaluation serves a fresh run and a recording read back, so the console, report.md,
figures.json, the exit status and a regression check of old runs all read the same
figures. Every check says whether it ran: `passed` is True or False where it did, None
("not checked") where it did not.
"""

from __future__ import annotations

import dataclasses
import signal
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vehil.protocol.schema import SCHEMA
from vehil.scenario import Tolerance


@dataclass
class Series:
    """A run's columns, wherever they came from, and how the run ended."""

    names: list[str]
    units: dict[str, str]
    t: np.ndarray
    board: np.ndarray  # (N, m)
    reference: np.ndarray  # (N, m), over the same N samples
    truth: dict[str, np.ndarray]
    status: np.ndarray
    cycles: np.ndarray
    rtt_s: np.ndarray
    late: np.ndarray
    tolerances: dict[str, Tolerance] = field(default_factory=dict)
    native: np.ndarray | None = None
    stack_bytes: int | None = None  # the board's stack high-water since boot, if it says
    board_name: str = ""
    native_board: bool = False  # the board is the native build: nothing to compare bits with
    ended: str = "completed"  # completed, interrupted or failed
    error: str | None = None
    expected: int | None = None  # samples the run was to have; None if not known
    stop_signal: int | None = None  # the signal that interrupted the run
    score_from_s: float = 0.0  # truth metrics from this time on (the scenario's)
    expect_flags: tuple[str, ...] = ()  # status flags the drive was built to raise


@dataclass(frozen=True)
class ReferenceCheck:
    """Board vs the float64 reference, against the scenario's tolerance."""

    rmse: float | None
    max_abs: float | None
    worst_k: int | None
    tolerance: Tolerance | None  # None: the scenario gives none, so nothing is checked
    outside_tolerance: int | None
    passed: bool | None


@dataclass(frozen=True)
class TruthCheck:
    """Board vs the truth (the reference's own error beside it), against `truth_rms`,
    over the samples from `from_s` on."""

    rmse: float | None
    max_abs: float | None
    worst_k: int | None
    reference_rmse: float | None
    limit: float | None  # the tolerance's truth_rms; None: not checked
    passed: bool | None
    from_s: float = 0.0


@dataclass(frozen=True)
class BitExactCheck:
    """FIXED: the board's bits against the native build's."""

    mismatches: int | None
    passed: bool | None
    not_checked_why: str = ""


@dataclass(frozen=True)
class OutputFigures:
    unit: str
    reference: ReferenceCheck
    truth: TruthCheck | None  # None: no truth for this output
    bit_exact: BitExactCheck | None  # None: not asked for

    def checks(self) -> dict[str, bool | None]:
        """Each check asked for, by short name: True, False, or None (did not run)."""
        found: dict[str, bool | None] = {"ref": self.reference.passed}
        if self.truth is not None and self.truth.limit is not None:
            found["truth"] = self.truth.passed
        if self.bit_exact is not None:
            found["bits"] = self.bit_exact.passed
        return found

    @property
    def passed(self) -> bool | None:
        """False if a check failed, True if one passed and none failed, None if none ran."""
        ran = [p for p in self.checks().values() if p is not None]
        return None if not ran else all(ran)

    def failed(self) -> list[str]:
        return [k for k, p in self.checks().items() if p is False]

    def not_checked(self) -> list[str]:
        return [k for k, p in self.checks().items() if p is None]


@dataclass(frozen=True)
class Verdict:
    """The run as a whole, computed once: the word, why, and the exit status it maps to."""

    word: str  # PASS, FAIL, NOT CHECKED, FAILED, INTERRUPTED
    reason: str
    exit_status: int

    @property
    def passed(self) -> bool:
        return self.word == "PASS"

    def __str__(self) -> str:
        return f"{self.word}: {self.reason}" if self.reason else self.word


# Exit statuses, as the README gives them.
EXIT_PASS, EXIT_FAIL, EXIT_ERROR = 0, 1, 2


@dataclass(frozen=True)
class Figures:
    samples: int
    expected: int | None
    outputs: dict[str, OutputFigures]
    cycles: dict[str, float | None]
    rtt_ms: dict[str, float | None]
    late: int
    stack_bytes: int | None
    status: dict[str, int]
    ended: str
    error: str | None
    verdict: Verdict

    @property
    def passed(self) -> bool:
        return self.verdict.passed

    def to_json(self) -> dict[str, Any]:
        """As figures.json holds them: every check with its `passed` (null: not checked)."""
        d = dataclasses.asdict(self)
        d["verdict"] = {"word": self.verdict.word, "reason": self.verdict.reason}
        d["exit_status"] = self.verdict.exit_status
        d["pass"] = self.passed
        for name, o in self.outputs.items():
            d["outputs"][name]["passed"] = o.passed
        return d


def _err_stats(err: np.ndarray) -> tuple[float | None, float | None, int | None]:
    if len(err) == 0:
        return None, None, None
    a = np.abs(err)
    return float(np.sqrt(np.mean(err**2))), float(a.max()), int(a.argmax())


def _output(s: Series, j: int, name: str) -> OutputFigures:
    n = len(s.board)
    tol = s.tolerances.get(name)
    b, r = s.board[:, j], s.reference[:, j]
    if tol is not None and n:
        rule = tol
        over = (np.abs(b - r) > rule.abs + rule.rel * np.abs(r)) & (s.t[:n] >= rule.from_s)
        outside: int | None = int(over.sum())
        ref_passed: bool | None = outside == 0
    else:
        outside, ref_passed = None, None
    reference = ReferenceCheck(*_err_stats(b - r), tol, outside, ref_passed)
    truth = None
    if name in s.truth:
        scored = np.flatnonzero(s.t[:n] >= s.score_from_s)
        true = s.truth[name][:n][scored]
        rmse, max_abs, worst = _err_stats(b[scored] - true)
        worst_k = None if worst is None else int(scored[worst])
        limit = tol.truth_rms if tol is not None else None
        truth_passed = None if limit is None or rmse is None else rmse <= limit
        ref_rmse = _err_stats(r[scored] - true)[0]
        truth = TruthCheck(rmse, max_abs, worst_k, ref_rmse, limit, truth_passed, s.score_from_s)
    bits = None
    if tol is not None and tol.bit_exact:
        if s.native is not None and n:
            mism = int(np.sum(b != s.native[:n, j]))
            bits = BitExactCheck(mism, mism == 0)
        elif s.native_board:
            bits = BitExactCheck(None, None, "the board is the native build itself")
        else:
            bits = BitExactCheck(None, None, "no native outputs to compare with")
    return OutputFigures(s.units.get(name, ""), reference, truth, bits)


def _flags_raised(s: Series) -> dict[str, int]:
    """Samples on which each status flag was set, for the flags that were."""
    counts = {name: int(np.sum((s.status & bit) != 0)) for name, bit in SCHEMA.status.items()}
    return {name: n for name, n in counts.items() if n}


def _health(s: Series, raised: dict[str, int]) -> str | None:
    """Why the estimator's health fails the run: it diverged where the drive was not built
    for it, or a flag the drive was built to raise never fired. None if neither."""
    if "DIVERGED" in raised and "DIVERGED" not in s.expect_flags:
        first = int(np.flatnonzero(s.status & SCHEMA.status["DIVERGED"])[0])
        return f"DIVERGED on {raised['DIVERGED']:,} samples (first at t = {s.t[first]:g} s)"
    missing = [f for f in s.expect_flags if f not in raised]
    if missing:
        return f"expected {', '.join(missing)}, never raised"
    return None


def _verdict(s: Series, outputs: dict[str, OutputFigures]) -> Verdict:
    n = len(s.board)
    of = f"{n:,} of {s.expected:,}" if s.expected is not None else f"{n:,}"
    if s.ended == "interrupted":
        number = s.stop_signal or signal.SIGINT
        why = s.error or f"stopped after {of} samples"
        return Verdict("INTERRUPTED", why, 128 + int(number))
    if s.ended != "completed":
        return Verdict("FAILED", s.error or f"after {of} samples", EXIT_ERROR)
    if s.expected is not None and n < s.expected:
        return Verdict("FAILED", f"incomplete: {of} samples", EXIT_ERROR)
    if n == 0:
        return Verdict("NOT CHECKED", "no samples", EXIT_FAIL)
    raised = _flags_raised(s)
    shown = "; flags: " + ", ".join(f"{k} x{v:,}" for k, v in raised.items()) if raised else ""
    failed = {name: o.failed() for name, o in outputs.items() if o.passed is False}
    if failed:
        where = "; ".join(f"{name} ({', '.join(checks)})" for name, checks in failed.items())
        return Verdict("FAIL", f"out of tolerance: {where}{shown}", EXIT_FAIL)
    unhealthy = _health(s, raised)
    if unhealthy:
        return Verdict("FAIL", f"{unhealthy}{shown}", EXIT_FAIL)
    unchecked = [name for name, o in outputs.items() if o.passed is None]
    if len(unchecked) == len(outputs):
        return Verdict(
            "NOT CHECKED",
            f"{n:,} samples, but no output has a tolerance ([tolerance.NAME] in the scenario)",
            EXIT_FAIL,
        )
    partial = [
        f"{name} {'/'.join(o.not_checked())}" for name, o in outputs.items() if o.not_checked()
    ]
    note = f"; not checked: {', '.join(partial)}" if partial else ""
    return Verdict("PASS", f"{of} samples checked{note}{shown}", EXIT_PASS)


def evaluate(s: Series) -> Figures:
    n = len(s.board)
    outputs = {name: _output(s, j, name) for j, name in enumerate(s.names)}
    flags = {name: int(np.sum((s.status & bit) != 0)) for name, bit in SCHEMA.status.items()}

    def pct(x: np.ndarray, q: float) -> float | None:
        return float(np.percentile(x, q)) if len(x) else None

    return Figures(
        samples=n,
        expected=s.expected,
        outputs=outputs,
        cycles={
            "min": int(s.cycles.min()) if n else None,
            "median": pct(s.cycles, 50),
            "max": int(s.cycles.max()) if n else None,
        },
        rtt_ms={
            "p50": pct(s.rtt_s * 1e3, 50),
            "p99": pct(s.rtt_s * 1e3, 99),
            "max": float(s.rtt_s.max() * 1e3) if n else None,
        },
        late=int(s.late.sum()),
        stack_bytes=s.stack_bytes,
        status=flags,
        ended=s.ended,
        error=s.error,
        verdict=_verdict(s, outputs),
    )


def diff_runs(a: Series, b: Series) -> dict[str, Any]:
    """Board output of run B against run A, sample by sample, over their common length
    and the outputs they share. Cycles are set side by side only for the same board."""
    n = min(len(a.board), len(b.board))
    common = [name for name in a.names if name in b.names]
    out: dict[str, Any] = {
        "samples": n,
        "lengths": [len(a.board), len(b.board)],
        "outputs": {},
        "only_in": [
            [x for x in a.names if x not in common],
            [x for x in b.names if x not in common],
        ],
    }
    for name in common:
        x, y = a.board[:n, a.names.index(name)], b.board[:n, b.names.index(name)]
        differ = np.flatnonzero(x != y)
        out["outputs"][name] = {
            "identical": len(differ) == 0,
            "differing_samples": int(len(differ)),
            "first_difference_k": int(differ[0]) if len(differ) else None,
            "max_abs": float(np.max(np.abs(y - x))) if n else 0.0,
        }
    out["same_time_base"] = bool(np.array_equal(a.t[:n], b.t[:n]))
    out["identical"] = (
        bool(common)
        and a.names == b.names
        and len(a.board) == len(b.board)
        and all(o["identical"] for o in out["outputs"].values())
    )
    out["boards"] = [a.board_name, b.board_name]
    out["cycles_comparable"] = a.board_name == b.board_name
    out["cycles_median"] = {
        label: float(np.median(s.cycles)) if len(s.cycles) else None
        for label, s in (("a", a), ("b", b))
    }
    return out


def series_from_recording(rec: Any) -> Series:
    """A vehil.record.Recording as a Series (tolerances and ending as recorded with the run)."""
    d = rec.data
    names = rec.outputs
    tolerances = {n: Tolerance(**t) for n, t in rec.header.get("tolerances", {}).items()}
    end = rec.end or {}
    board = rec.header.get("board", {}).get("name", "")
    return Series(
        names=names,
        units=rec.units,
        t=d["t"],
        board=np.column_stack([d[f"board.{n}"] for n in names]) if names else np.empty((0, 0)),
        reference=np.column_stack([d[f"ref.{n}"] for n in names]) if names else np.empty((0, 0)),
        truth={n: d[f"truth.{n}"] for n in names if f"truth.{n}" in d},
        status=d["status"],
        cycles=d["cycles"].astype(np.int64),
        rtt_s=d["rtt_s"],
        late=d["late"].astype(bool),
        tolerances=tolerances,
        stack_bytes=end.get("stack_bytes"),
        board_name=board,
        native_board=board == "native",
        # A recording without its end record did not finish: it cannot pass.
        ended=end.get("ended", "failed"),
        error=end.get("error") if rec.end else f"recording {rec.truncated}",
        expected=rec.header.get("expected_samples"),
        stop_signal=end.get("signal"),
        score_from_s=rec.header.get("scenario", {}).get("score_from_s", 0.0),
        expect_flags=tuple(rec.header.get("scenario", {}).get("expect_flags", ())),
    )


def series_from_run(run: Any) -> Series:
    """A vehil.runner.Run as a Series."""
    p = run.prepared
    n = run.done
    spec = p.scenario.estimator
    return Series(
        names=p.output_names,
        units={s.name: s.unit for s in (*spec.inputs, *spec.outputs)},
        t=p.trace.t[:n],
        board=run.board_out,
        reference=p.reference[:n],
        truth={k: v[:n] for k, v in p.truth().items()},
        status=run.status,
        cycles=run.cycles,
        rtt_s=run.rtt_s,
        late=run.late,
        tolerances=dict(p.scenario.tolerances),
        native=run.native_out,
        stack_bytes=run.stack_bytes,
        board_name=run.board,
        native_board=run.board == "native",
        ended=run.ended,
        error=run.error,
        expected=run.expected,
        stop_signal=run.stop_signal,
        score_from_s=p.scenario.score_from_s,
        expect_flags=p.scenario.expect_flags,
    )
