"""Recorded drives as a run's input: CSV, MDF4 (asammdf), raw CAN with a DBC, or a vehil
recording.

Each mapped channel is read with its own time stamps and unit, cleaned on its own
(missing values dropped, duplicated stamps merged), converted to the unit the estimator
wants (pint), checked for gaps, and resampled onto the scenario's grid (low-passed first
where it is decimated); the grid covers only the time where every channel has data.
Every problem names the file, and the column or line. `LogTrace.timing` says, per
channel, what was done, for the run's report (docs/logs.md).
"""

from __future__ import annotations

import gc
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import signal

from vehil import units
from vehil.csvlog import Columns, LogError, read_columns
from vehil.estimators.base import EstimatorSpec
from vehil.plants.base import Trace
from vehil.scenario import ColumnMap, LogSource


@dataclass
class Channel:
    """One logged signal on its own time stamps; x is NaN where the log has no value."""

    name: str
    t: np.ndarray
    x: np.ndarray
    unit: str
    lines: np.ndarray | None = None  # a CSV's file line of each sample
    missing: int = 0
    merged: str = ""  # duplicated stamps merged, and where the first was

    def place(self, i: int) -> str:
        where = f"line {self.lines[i]}" if self.lines is not None else f"sample {i}"
        return f"{where}, column {self.name}"


@dataclass
class LogTrace(Trace):
    timing: list[dict[str, str]] = field(default_factory=list)  # one row per mapped input
    notes: list[str] = field(default_factory=list)  # what was trimmed or split, and why


def read_mdf4(path: Path, channels: list[str]) -> Columns:
    from asammdf import MDF  # imported here: it is slow to import and only MDF needs it

    try:
        mdf = MDF(str(path))
    except Exception as exc:  # asammdf raises many types for a bad file
        reason = str(exc)
    else:
        reason = ""
    if reason:
        _collect_quietly()
        raise LogError(f"{path}: not a readable MDF file: {reason}")
    values, units_of = {}, {}
    with mdf:
        for name in channels:
            try:
                sig = mdf.get(name)
            except Exception:
                known = sorted(mdf.channels_db)[:20]
                raw = "CAN_DataFrame" in mdf.channels_db
                bus = " (raw CAN frames: set [log] dbc and map MESSAGE.SIGNAL)" if raw else ""
                raise LogError(
                    f"{path}: no channel {name!r}; some channels: {', '.join(known)}{bus}"
                ) from None
            values[name] = np.asarray(sig.samples, dtype=np.float64)
            values[f"{name}@t"] = np.asarray(sig.timestamps, dtype=np.float64)
            units_of[name] = sig.unit or ""
    return Columns(values, units_of)


def _collect_quietly() -> None:
    """Collects what a failed MDF() left: asammdf's half-built reader fails in its __del__
    (no file attribute), which would print a traceback below the error."""
    hook = sys.unraisablehook
    sys.unraisablehook = lambda _: None
    try:
        gc.collect()
    finally:
        sys.unraisablehook = hook


def read_recording(path: Path) -> Columns:
    """A vehil recording's inputs and truths, as columns named like the estimator's signals."""
    from vehil import record

    rec = record.read(path)
    values = {"t": rec.data["t"]}
    units_of = {"t": "s"}
    for col, arr in rec.data.items():
        for prefix in ("in.", "truth."):
            if col.startswith(prefix):
                name = col[len(prefix) :]
                key = name if prefix == "in." else f"truth.{name}"
                values[key] = arr
                units_of[key] = rec.units.get(name, "")
    return Columns(values, units_of)


def read_channels(log: LogSource, names: list[str]) -> dict[str, Channel]:
    """The named channels of the log, each on its own time stamps (in s)."""
    if not names:
        return {}
    if log.dbc is not None:
        from vehil.canlog import read_can

        got = read_can(log.path, log.format, log.dbc, names)
        return {n: Channel(n, t, x, u) for n, (t, x, u) in got.items()}
    if log.format == "csv":
        cols = read_columns(
            log.path,
            names,
            log.time,
            units_row=log.units_row,
            time_format=log.time_format,
            delimiter=log.delimiter,
            decimal=log.decimal,
        )
        t_unit = cols.t_unit or log.time_unit
        if not t_unit:
            raise LogError(
                f"{log.path}: time column {log.time!r} has no unit: write it in the header "
                f"(`{log.time} [s]`) or set [log] time_unit"
            )
        try:
            t = units.convert(cols.t, t_unit, "s")
        except units.UnitError as exc:
            raise LogError(f"{log.path}: time column {log.time!r}: {exc}") from None
        return {n: Channel(n, t, cols.values[n], cols.units[n], cols.lines) for n in names}
    named = read_mdf4(log.path, names) if log.format == "mdf4" else read_recording(log.path)
    out = {}
    for n in names:
        if n not in named.values:
            known = ", ".join(c for c in named.values if not c.endswith("@t"))
            raise LogError(f"{log.path}: no column {n!r}; columns: {known}{_whose(log)}")
        stamps = named.values.get(f"{n}@t", named.values.get("t"))
        assert stamps is not None
        out[n] = Channel(n, stamps, named.values[n], named.units.get(n, ""))
    return out


def _whose(log: LogSource) -> str:
    """For a recording: whose inputs it holds, and so which scenarios can replay it."""
    if log.format != "vehil":
        return ""
    from vehil import record

    name = record.read(log.path).header["estimator"]["name"]
    return f" (a run of {name}: replay it with a scenario of {name})"


def clean(ch: Channel, path: Path) -> Channel:
    """The channel's valid samples: missing values dropped, duplicated stamps merged (their
    mean); time that goes back, or infinities, are refused where they are."""
    inf = np.flatnonzero(np.isinf(ch.x) | np.isinf(ch.t))
    if len(inf):
        raise LogError(
            f"{path}: {ch.place(inf[0])}: {ch.x[inf[0]]} is not a finite number "
            f"({len(inf)} such values in the column): clean the log or drop those rows"
        )
    keep = ~(np.isnan(ch.x) | np.isnan(ch.t))
    lines = ch.lines[keep] if ch.lines is not None else None
    c = Channel(ch.name, ch.t[keep], ch.x[keep], ch.unit, lines, int((~keep).sum()))
    if len(c.t) < 2:
        raise LogError(
            f"{path}: column {ch.name} has {len(c.t)} samples with a value "
            f"({c.missing} missing); it needs two"
        )
    d = np.diff(c.t)
    back = np.flatnonzero(d < 0)
    done = []
    if len(back):
        # Stamps a little out of order (a logger interleaving buses or DAQ lists) are
        # sorted; time that goes back further (a restarted logger, two drives) is refused.
        half = 0.5 * float(np.median(d[d > 0])) if np.any(d > 0) else 0.0
        far = back[-d[back] >= half]
        if len(far):
            i = far[0] + 1
            raise LogError(
                f"{path}: {c.place(i)}: time {_at(c.t[i])} s goes back from {_at(c.t[i - 1])} s "
                f"before it, half a step or more ({len(far)} such steps): time must increase "
                "(equal stamps are merged, stamps less than half a step out of order sorted): "
                "cut the log where its time starts again, or sort it by time"
            )
        done.append(f"{len(back)} stamps out of order sorted, first at {c.place(back[0] + 1)}")
        order = np.argsort(c.t, kind="stable")
        c.t, c.x = c.t[order], c.x[order]
        c.lines = c.lines[order] if c.lines is not None else None
    same = np.flatnonzero(np.diff(c.t) == 0)
    if len(same):
        stamps, first, group = np.unique(c.t, return_index=True, return_inverse=True)
        x = np.bincount(group, weights=c.x) / np.bincount(group)
        done.append(f"{len(same)} duplicated stamps merged (mean), first at {c.place(same[0] + 1)}")
        c.t, c.x = stamps, x
        c.lines = c.lines[first] if c.lines is not None else None
    c.merged = "; ".join(done)
    return c


def _at(t: float) -> str:
    """A time in s as a log has it: 6 digits, or to the ms where it is large (an epoch's
    stamps, 1700000019.9 s, which 6 digits would print as 1.7e+09)."""
    return f"{t:.6g}" if abs(t) < 1e5 else f"{t:.3f}".rstrip("0").rstrip(".")


@dataclass
class _Timing:
    rate: float  # Hz, from the median step
    jitter: float  # s, the standard deviation of the steps
    limit: float  # s, the longest step that is not a gap
    gaps: np.ndarray  # indices i with t[i + 1] - t[i] > limit


def _timing(c: Channel, max_gap_s: float | None) -> _Timing:
    d = np.diff(c.t)
    step = float(np.median(d))
    limit = max_gap_s if max_gap_s is not None else 5 * step
    return _Timing(1 / step, float(np.std(d)), limit, np.flatnonzero(d > limit))


def _gaps(c: Channel, tm: _Timing) -> str:
    if not len(tm.gaps):
        return f"none over {tm.limit:.3g} s"
    longest = float(np.max(np.diff(c.t)))
    return f"{len(tm.gaps)} over {tm.limit:.3g} s (longest {longest:.3g} s)"


def _stretches(c: Channel, tm: _Timing) -> list[tuple[float, float]]:
    edges = [0, *(tm.gaps + 1)], [*tm.gaps, len(c.t) - 1]
    return [(c.t[a], c.t[b]) for a, b in zip(*edges, strict=True)]


def _split(
    chans: dict[str, Channel], timing: dict[str, _Timing]
) -> tuple[tuple[float, float], list[tuple[float, float]]]:
    """The stretches where every channel has data with no gap; the longest first."""
    pieces = [(-math.inf, math.inf)]
    for name, c in chans.items():
        pieces = [
            (max(a, c0), min(b, c1))
            for a, b in pieces
            for c0, c1 in _stretches(c, timing[name])
            if max(a, c0) < min(b, c1)
        ]
    if not pieces:
        raise LogError("the channels share no stretch without a gap")
    return max(pieces, key=lambda p: p[1] - p[0]), pieces


def _span(
    log: LogSource, chans: dict[str, Channel], timing: dict[str, _Timing]
) -> tuple[tuple[float, float], list[str]]:
    """The stretch of the log the run covers: where every channel has data (and, with
    on_gap = "split", no gap); the channels are cut to it. Notes say what was left out."""
    first = {n: c.t[0] for n, c in chans.items()}
    last = {n: c.t[-1] for n, c in chans.items()}
    starts, ends = max(first, key=first.__getitem__), min(last, key=last.__getitem__)
    span = (first[starts], last[ends])
    notes = []
    if first[starts] > min(first.values()):
        notes.append(f"the run starts where {starts} starts (t = {_at(first[starts])} s)")
    if last[ends] < max(last.values()):
        notes.append(
            f"the run ends where {ends} ends (t = {_at(last[ends])} s; the log goes on to "
            f"{_at(max(last.values()))} s)"
        )
    gaps = sorted(
        ((n, i) for n, tm in timing.items() for i in tm.gaps), key=lambda g: chans[g[0]].t[g[1]]
    )
    if not gaps:
        return span, notes
    n, i = gaps[0]
    c, tm = chans[n], timing[n]
    if log.on_gap == "refuse":
        raise LogError(
            f"{log.path}: {c.place(i + 1)}: no value for {c.t[i + 1] - c.t[i]:.3g} s "
            f"(t = {_at(c.t[i])} to {_at(c.t[i + 1])} s), past the {tm.limit:.3g} s a gap may "
            f"span ({len(gaps)} such gaps): set [log] max_gap_s above it to bridge it by a "
            'straight line, or on_gap = "split" to run the longest stretch without one'
        )
    try:
        span, pieces = _split(chans, timing)
    except LogError as exc:
        raise LogError(f"{log.path}: {exc}") from None
    for c in chans.values():  # the stretch alone: no filter runs across a gap
        inside = (c.t >= span[0]) & (c.t <= span[1])
        c.t, c.x = c.t[inside], c.x[inside]
        c.lines = c.lines[inside] if c.lines is not None else None
    shown = ", ".join(f"{_at(a)}-{_at(b)} s" for a, b in pieces)
    notes.append(
        f"split at {len(gaps)} gaps longer than max_gap_s: stretches {shown}; "
        f"running {_at(span[0])}-{_at(span[1])} s"
    )
    return span, notes


def _on_grid(c: Channel, tm: _Timing, grid: np.ndarray, T: float) -> tuple[np.ndarray, str]:
    """The channel on the grid, and how it got there."""
    fs = 1 / T
    k = np.clip(np.searchsorted(c.t, grid), 1, len(c.t) - 1)
    k -= grid - c.t[k - 1] < c.t[k] - grid  # the nearest sample
    off = np.abs(c.t[k] - grid)
    if np.all(off <= 0.05 * T) and abs(tm.rate - fs) <= 0.01 * fs and len(np.unique(k)) == len(k):
        # A regular log at the run's rate: its samples as they are, stamp jitter and all.
        late = off.max()
        jitter = f", stamps within {late * 1e3:.2g} ms of the grid" if late > 1e-6 * T else ""
        return c.x[k], f"as logged ({tm.rate:.4g} Hz{jitter})"
    if tm.rate > 1.05 * fs:
        # Decimation: low-pass below the grid's Nyquist on the channel's own uniform grid.
        own = np.arange(c.t[0], c.t[-1], 1 / tm.rate)
        cutoff = 0.4 * fs
        sos = signal.butter(4, cutoff, fs=tm.rate, output="sos")
        x = signal.sosfiltfilt(sos, np.interp(own, c.t, c.x), padlen=min(27, len(own) - 1))
        return np.interp(grid, own, x), (
            f"low-pass {cutoff:.3g} Hz (Butterworth 4, zero phase), {tm.rate:.4g} → {fs:.4g} Hz"
        )
    return np.interp(grid, c.t, c.x), f"linear interpolation {tm.rate:.4g} → {fs:.4g} Hz"


def _unit_error(path: Path, cm: ColumnMap, role: str, want: str, what: str) -> LogError:
    return LogError(
        f"{path}: column {cm.column!r} for {role}: {what}; {role} needs {want!r}: state the "
        f'column\'s unit in the scenario: {{ column = "{cm.column}", unit = "..." }}'
    )


def _convert(
    path: Path, cm: ColumnMap, unit: str, x: np.ndarray, want: str, role: str, T: float
) -> tuple[np.ndarray, str]:
    """The mapped value in the wanted unit, and a word on the conversion."""
    if not unit:
        raise _unit_error(path, cm, role, want, "it has no unit")
    if not units.known(unit):
        raise _unit_error(path, cm, role, want, f"its unit {unit!r} is not one vehil knows")
    per = ""
    x = x * cm.scale + cm.offset
    how = [] if (cm.scale, cm.offset) == (1.0, 0.0) else [f"× {cm.scale:g} + {cm.offset:g}"]
    if cm.derivative:
        cut = min(cm.cutoff_hz, 0.4 / T)
        sos = signal.butter(2, cut, fs=1 / T, output="sos")
        x = np.gradient(signal.sosfiltfilt(sos, x, padlen=min(9, len(x) - 1)), T)
        per = "s"
        how.append(f"d/dt low-passed at {cut:.3g} Hz")
    if cm.radius is not None:
        per = "m"
        x = x / cm.radius
        how.append(f"/ radius {cm.radius:g} m")
    try:
        y = units.convert(x, unit, want, per)
    except units.UnitError as exc:
        raise _unit_error(path, cm, role, want, str(exc)) from None
    if not units.same(unit, want, per):
        how.append(f"({unit})/{per} → {want}" if per else f"{unit} → {want}")
    return y, ", ".join(how) or f"{unit} (as logged)"


def _mapped(
    log: LogSource, spec: EstimatorSpec
) -> tuple[dict[str, ColumnMap], dict[str, ColumnMap], dict[str, Channel]]:
    """The inputs' and truths' mappings, and the cleaned channels they read."""
    maps = {s.name: ColumnMap.of(log.columns.get(s.name, s.name)) for s in spec.inputs}
    truths = dict(log.truth)
    if log.format == "vehil":
        # A recording carries the estimator's signals by name: a log's mapping does not apply.
        maps = {s.name: ColumnMap(column=s.name) for s in spec.inputs}
        recorded = read_recording(log.path).values
        truths = {s.name: f"truth.{s.name}" for s in spec.outputs if f"truth.{s.name}" in recorded}
    truth_maps = {f"truth.{n}": ColumnMap.of(c) for n, c in truths.items()}
    names = sorted({m.column for m in (*maps.values(), *truth_maps.values()) if m.column})
    chans = {n: clean(c, log.path) for n, c in read_channels(log, names).items()}
    return maps, truth_maps, chans


def own_step(log: LogSource, spec: EstimatorSpec) -> float:
    """The log's own sample time, where every mapped channel is logged at one regular rate
    (steps within 1 % of each other): a run then takes the samples as logged."""
    _, _, chans = _mapped(log, spec)
    steps = {n: np.diff(c.t) for n, c in chans.items()}
    if not steps:
        raise LogError(f"{log.path}: [log.columns] maps no logged channel")
    mean = {n: (c.t[-1] - c.t[0]) / (len(c.t) - 1) for n, c in chans.items()}
    T = float(np.median(list(mean.values())))
    regular = all(np.all(np.abs(d - T) <= 0.01 * T) for d in steps.values())
    if not regular:
        shown = ", ".join(
            f"{n} {1 / mean[n]:.4g} Hz (steps {d.min() * 1e3:.3g}-{d.max() * 1e3:.3g} ms)"
            for n, d in steps.items()
        )
        raise LogError(
            f"{log.path}: the log has no one regular rate: {shown}; give a number of seconds"
        )
    return T


def trace_from_log(
    log: LogSource, spec: EstimatorSpec, sample_time: float, duration: float
) -> LogTrace:
    T = sample_time
    inputs = {s.name: s for s in spec.inputs}
    maps, truth_maps, chans = _mapped(log, spec)
    all_maps = {**maps, **truth_maps}
    wants = {
        **{n: s.unit for n, s in inputs.items()},
        **{f"truth.{s.name}": s.unit for s in spec.outputs},
    }
    timing = {n: _timing(c, log.max_gap_s) for n, c in chans.items()}
    if not chans:
        raise LogError(f"{log.path}: [log.columns] maps no logged channel: map one at least")
    span, notes = _span(log, chans, timing)
    timing = {n: _timing(c, log.max_gap_s) for n, c in chans.items()}  # of the stretch run
    n_samples = int(math.floor(min(span[1] - span[0], duration) / T + 1e-9)) + 1
    grid = span[0] + np.arange(n_samples) * T
    on_grid = {n: _on_grid(c, timing[n], grid, T) for n, c in chans.items()}
    values, rows = {}, []
    for key, cm in all_maps.items():
        role = f"input {key}" if key in inputs else f"the truth of {key[6:]}"
        want = wants[key]
        if cm.column is None:
            assert cm.value is not None
            x = np.full(n_samples, cm.value)
            values[key], how = _convert(log.path, cm, cm.unit or want, x, want, role, T)
            rows.append(
                {"input": key, "source": f"constant {cm.value:g}", "unit": how if cm.unit else want}
            )
            continue
        c, tm = chans[cm.column], timing[cm.column]
        x, resampled = on_grid[cm.column]
        values[key], how = _convert(log.path, cm, cm.unit or c.unit, x, want, role, T)
        rows.append(
            {
                "input": key,
                "source": cm.column,
                "unit": how,
                "rate": f"{tm.rate:.4g} Hz",
                "jitter": f"{tm.jitter * 1e3:.3g} ms" if tm.jitter > 1e-9 else "0 ms",
                "gaps": _gaps(c, tm),
                "missing": str(c.missing),
                "duplicates": c.merged or "0",
                "logged": f"{_at(c.t[0])}-{_at(c.t[-1])} s",
                "resampling": resampled,
            }
        )
    return LogTrace(
        t=grid - span[0],
        signals={n: values[n] for n in maps},
        truth={k[6:]: values[k] for k in truth_maps},
        units={s.name: s.unit for s in (*spec.inputs, *spec.outputs)},
        timing=rows,
        notes=notes,
    )
