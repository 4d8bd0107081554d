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


class _Errors:
    """RMS, largest |error| and where, over chunks: sums and maxima, never the samples."""

    def __init__(self) -> None:
        self.n = 0
        self.sumsq = 0.0
        self.max_abs = -1.0
        self.worst_k = 0

    def add(self, err: np.ndarray, ks: np.ndarray) -> None:
        if not len(err):
            return
        a = np.abs(err)
        i = int(a.argmax())
        if a[i] > self.max_abs:  # the first of equal maxima, as argmax over the whole
            self.max_abs, self.worst_k = float(a[i]), int(ks[i])
        self.sumsq += float(np.sum(err**2))
        self.n += len(err)

    def stats(self) -> tuple[float | None, float | None, int | None]:
        if not self.n:
            return None, None, None
        return float(np.sqrt(self.sumsq / self.n)), self.max_abs, self.worst_k


class _Output:
    def __init__(self, tol: Tolerance | None, has_truth: bool):
        self.tol = tol
        self.ref = _Errors()
        self.outside = 0
        self.checked = 0  # samples from the tolerance's from_s and from_samples on
        self.truth = _Errors() if has_truth else None
        self.ref_vs_truth = _Errors()
        self.mismatches: int | None = None


def _lerp(a: float, b: float, g: float) -> float:
    """numpy's linear interpolation between order statistics, to its rounding."""
    d = b - a
    return b - d * (1 - g) if g >= 0.5 else a + d * g


class _Quantiles:
    """Exact percentiles of integer values (cycles) from their counts."""

    def __init__(self) -> None:
        self.counts: dict[int, int] = {}

    def add(self, x: np.ndarray) -> None:
        values, counts = np.unique(x, return_counts=True)
        for v, c in zip(values.tolist(), counts.tolist(), strict=True):
            self.counts[v] = self.counts.get(v, 0) + c

    def order_stat(self, values: np.ndarray, cum: np.ndarray, i: int) -> float:
        return float(values[int(np.searchsorted(cum, i, side="right"))])

    def percentile(self, q: float) -> float | None:
        if not self.counts:
            return None
        values = np.array(sorted(self.counts))
        cum = np.cumsum([self.counts[v] for v in values])
        h = (cum[-1] - 1) * (q / 100)
        lo = int(np.floor(h))
        a = self.order_stat(values, cum, lo)
        b = self.order_stat(values, cum, min(lo + 1, int(cum[-1]) - 1))
        return _lerp(a, b, h - lo)


# Round trips (host clock, seconds) counted in log-spaced bins: 1000 a decade from 100 ns
# to 1000 s, so a percentile is within 0.12 % whatever the run's length.
_RTT_EDGES = np.logspace(-7, 3, 10_001)


class _Latency:
    def __init__(self) -> None:
        self.counts = np.zeros(len(_RTT_EDGES) + 1, dtype=np.int64)
        self.max = 0.0

    def add(self, rtt: np.ndarray) -> None:
        if len(rtt):
            self.counts += np.bincount(np.searchsorted(_RTT_EDGES, rtt), minlength=len(self.counts))
            self.max = max(self.max, float(rtt.max()))

    def percentile(self, q: float) -> float | None:
        n = int(self.counts.sum())
        if not n:
            return None
        i = int(np.searchsorted(np.cumsum(self.counts), (n - 1) * q / 100, side="right"))
        lo = _RTT_EDGES[max(i - 1, 0)]
        hi = _RTT_EDGES[min(i, len(_RTT_EDGES) - 1)]
        return min(float(np.sqrt(lo * hi)), self.max)  # the bin's middle


class Metrics:
    """A run's figures accumulated chunk by chunk (as recorded, or as read back), so a run
    of any length is judged in the memory of one chunk; `figures()` gives the verdict."""

    def __init__(
        self,
        names: list[str],
        units: dict[str, str],
        tolerances: dict[str, Tolerance],
        truth_names: list[str] | tuple[str, ...],
        score_from_s: float = 0.0,
        expect_flags: tuple[str, ...] = (),
    ):
        self.names, self.units, self.score_from_s = names, units, score_from_s
        self.expect_flags = expect_flags  # status flags the drive was built to raise
        self.first_diverged_t: float | None = None
        self.outputs = {n: _Output(tolerances.get(n), n in truth_names) for n in names}
        self.samples = 0
        self.cycles = _Quantiles()
        self.cycles_min: int | None = None
        self.cycles_max: int | None = None
        self.rtt = _Latency()
        self.late = 0
        self.flags = dict.fromkeys(SCHEMA.status, 0)

    def add(
        self,
        t: np.ndarray,
        board: np.ndarray,
        reference: np.ndarray,
        truth: dict[str, np.ndarray],
        status: np.ndarray,
        cycles: np.ndarray,
        rtt_s: np.ndarray,
        late: np.ndarray,
        native: np.ndarray | None = None,
    ) -> None:
        """Samples `samples` .. `samples + len(board) - 1`, in order."""
        n = len(board)
        if not n:
            return
        ks = np.arange(self.samples, self.samples + n)
        t = t[:n]
        scored = t >= self.score_from_s
        for j, name in enumerate(self.names):
            o = self.outputs[name]
            b, r = board[:, j], reference[:n, j]
            o.ref.add(b - r, ks)
            if o.tol is not None:
                checked = (t >= o.tol.from_s) & (ks >= o.tol.from_samples)
                over = (np.abs(b - r) > o.tol.abs + o.tol.rel * np.abs(r)) & checked
                o.outside += int(over.sum())
                o.checked += int(checked.sum())
            if o.truth is not None:
                true = truth[name][:n][scored]
                o.truth.add(b[scored] - true, ks[scored])
                o.ref_vs_truth.add(r[scored] - true, ks[scored])
            if native is not None:
                o.mismatches = (o.mismatches or 0) + int(np.sum(b != native[:n, j]))
        c = cycles.astype(np.int64)
        self.cycles.add(c)
        lo, hi = int(c.min()), int(c.max())
        self.cycles_min = lo if self.cycles_min is None else min(self.cycles_min, lo)
        self.cycles_max = hi if self.cycles_max is None else max(self.cycles_max, hi)
        self.rtt.add(rtt_s)
        self.late += int(np.sum(late))
        for flag, bit in SCHEMA.status.items():
            self.flags[flag] += int(np.sum((status & bit) != 0))
        diverged = np.flatnonzero(status & SCHEMA.status["DIVERGED"])
        if self.first_diverged_t is None and len(diverged):
            self.first_diverged_t = float(t[diverged[0]])
        self.samples += n

    def add_columns(self, d: dict[str, np.ndarray]) -> None:
        """A recording's batch, by its column names (vehil.record)."""
        names = self.names
        empty = np.empty((len(d["k"]), 0))
        self.add(
            d["t"],
            np.column_stack([d[f"board.{n}"] for n in names]) if names else empty,
            np.column_stack([d[f"ref.{n}"] for n in names]) if names else empty,
            {n: d[f"truth.{n}"] for n in names if f"truth.{n}" in d},
            d["status"],
            d["cycles"],
            d["rtt_s"],
            d["late"],
        )

    def _output(self, name: str, native_board: bool) -> OutputFigures:
        o = self.outputs[name]
        tol = o.tol
        if tol is not None and o.checked:
            outside: int | None = o.outside
            ref_passed: bool | None = outside == 0
        else:
            outside, ref_passed = None, None
        reference = ReferenceCheck(*o.ref.stats(), tol, outside, ref_passed)
        truth = None
        if o.truth is not None:
            rmse, max_abs, worst_k = o.truth.stats()
            limit = tol.truth_rms if tol is not None else None
            truth_passed = None if limit is None or rmse is None else rmse <= limit
            ref_rmse = o.ref_vs_truth.stats()[0]
            truth = TruthCheck(
                rmse, max_abs, worst_k, ref_rmse, limit, truth_passed, self.score_from_s
            )
        bits = None
        if tol is not None and tol.bit_exact:
            if o.mismatches is not None and self.samples:
                bits = BitExactCheck(o.mismatches, o.mismatches == 0)
            elif native_board:
                bits = BitExactCheck(None, None, "the board is the native build itself")
            else:
                bits = BitExactCheck(None, None, "no native outputs to compare with")
        return OutputFigures(self.units.get(name, ""), reference, truth, bits)

    def figures(
        self,
        *,
        ended: str = "completed",
        error: str | None = None,
        expected: int | None = None,
        stop_signal: int | None = None,
        stack_bytes: int | None = None,
        native_board: bool = False,
        mismatches: dict[str, int] | None = None,
    ) -> Figures:
        """The figures and the verdict; `mismatches`: per output, samples whose bits differ
        from the native build's (counted apart from the run, see runner.native_mismatches)."""
        for name, count in (mismatches or {}).items():
            self.outputs[name].mismatches = count
        outputs = {name: self._output(name, native_board) for name in self.names}
        n = self.samples
        rtt_ms = {
            "p50": _ms(self.rtt.percentile(50)),
            "p99": _ms(self.rtt.percentile(99)),
            "max": self.rtt.max * 1e3 if n else None,
        }
        return Figures(
            samples=n,
            expected=expected,
            outputs=outputs,
            cycles={
                "min": self.cycles_min,
                "median": self.cycles.percentile(50),
                "max": self.cycles_max,
            },
            rtt_ms=rtt_ms,
            late=self.late,
            stack_bytes=stack_bytes,
            status=dict(self.flags),
            ended=ended,
            error=error,
            verdict=_verdict(
                n, expected, ended, error, stop_signal, outputs, self._health(), self.late
            ),
        )

    def _health(self) -> tuple[dict[str, int], str | None]:
        """The flags raised (samples each), and why the estimator's health fails the run:
        it diverged where the drive was not built for it, or a flag the drive was built
        to raise never fired (None if neither)."""
        raised = {name: n for name, n in self.flags.items() if n}
        if "DIVERGED" in raised and "DIVERGED" not in self.expect_flags:
            first = self.first_diverged_t
            return raised, f"DIVERGED on {raised['DIVERGED']:,} samples (first at t = {first:g} s)"
        missing = [f for f in self.expect_flags if f not in raised]
        if missing:
            return raised, f"expected {', '.join(missing)}, never raised"
        return raised, None


def _ms(s: float | None) -> float | None:
    return None if s is None else s * 1e3


def _verdict(
    n: int,
    expected: int | None,
    ended: str,
    error: str | None,
    stop_signal: int | None,
    outputs: dict[str, OutputFigures],
    health: tuple[dict[str, int], str | None],
    late: int = 0,
) -> Verdict:
    of = f"{n:,} of {expected:,}" if expected is not None else f"{n:,}"
    if ended == "interrupted":
        number = stop_signal or signal.SIGINT
        why = error or f"stopped after {of} samples"
        return Verdict("INTERRUPTED", why, 128 + int(number))
    if ended != "completed":
        return Verdict("FAILED", error or f"after {of} samples", EXIT_ERROR)
    if expected is not None and n < expected:
        return Verdict("FAILED", f"incomplete: {of} samples", EXIT_ERROR)
    if n == 0:
        return Verdict("NOT CHECKED", "no samples", EXIT_FAIL)
    raised, unhealthy = health
    shown = "; flags: " + ", ".join(f"{k} x{v:,}" for k, v in raised.items()) if raised else ""
    if late:  # real time: results that came after the next sample was due
        shown += f"; {late:,} late"
    failed = {name: o.failed() for name, o in outputs.items() if o.passed is False}
    if failed:
        where = "; ".join(f"{name} ({', '.join(checks)})" for name, checks in failed.items())
        return Verdict("FAIL", f"out of tolerance: {where}{shown}", EXIT_FAIL)
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
    """A Series held whole, judged as one chunk."""
    m = Metrics(s.names, s.units, s.tolerances, list(s.truth), s.score_from_s, s.expect_flags)
    m.add(s.t, s.board, s.reference, s.truth, s.status, s.cycles, s.rtt_s, s.late, s.native)
    return m.figures(
        ended=s.ended,
        error=s.error,
        expected=s.expected,
        stop_signal=s.stop_signal,
        stack_bytes=s.stack_bytes,
        native_board=s.native_board,
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


def drive_difference(a: Any, b: Any) -> str | None:
    """Why recordings A and B are not runs of one drive, or None: the same input signals on
    the same time base with the same values (a closed loop's only at the first sample:
    after it the inputs follow each run's own board)."""
    ins_a = sorted(k for k in a.data if k.startswith("in."))
    ins_b = sorted(k for k in b.data if k.startswith("in."))
    if ins_a != ins_b:
        names = [", ".join(k[3:] for k in ins) or "none" for ins in (ins_a, ins_b)]
        return f"their inputs differ: A's are {names[0]}, B's {names[1]}"
    n = min(len(a), len(b))
    if not np.array_equal(a.data["t"][:n], b.data["t"][:n]):
        k = int(np.flatnonzero(a.data["t"][:n] != b.data["t"][:n])[0])
        return (
            f"their time differs from sample {k} (A {a.data['t'][k]:g} s, B {b.data['t'][k]:g} s)"
        )
    closed = any(r.header.get("scenario", {}).get("closed_loop") for r in (a, b))
    m = min(n, 1) if closed else n
    for key in ins_a:
        x, y = a.data[key][:m], b.data[key][:m]
        differ = np.flatnonzero(~((x == y) | (np.isnan(x) & np.isnan(y))))
        if len(differ):
            k = int(differ[0])
            return f"input {key[3:]} differs from sample {k} (A {x[k]:.9g}, B {y[k]:.9g})"
    return None


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
