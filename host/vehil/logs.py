"""Recorded drives as a run's input: CSV, MDF4 (asammdf) or a vehil recording.

Every reader returns named columns with units; `trace_from_log` then picks the
estimator's inputs and truths by the scenario's column mapping, checks units and
values, and puts them on the scenario's sample grid. Every problem names the
file, and the column or line.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from vehil.csvlog import Columns, LogError, read_csv
from vehil.estimators.base import EstimatorSpec
from vehil.plants.base import Trace
from vehil.scenario import LogSource


def read_mdf4(path: Path, channels: list[str]) -> Columns:
    from asammdf import MDF  # imported here: it is slow to import and only MDF needs it

    try:
        mdf = MDF(str(path))
    except Exception as exc:  # asammdf raises many types for a bad file
        raise LogError(f"{path}: not a readable MDF file: {exc}") from None
    values, units = {}, {}
    with mdf:
        for name in channels:
            try:
                sig = mdf.get(name)
            except Exception:
                known = sorted(mdf.channels_db)[:20]
                raise LogError(
                    f"{path}: no channel {name!r}; some channels: {', '.join(known)}"
                ) from None
            values[name] = np.asarray(sig.samples, dtype=np.float64)
            values[f"{name}@t"] = np.asarray(sig.timestamps, dtype=np.float64)
            units[name] = sig.unit or ""
    return Columns(values, units)


def read_recording(path: Path) -> Columns:
    """A vehil recording's inputs and truths, as columns named like the estimator's signals."""
    from vehil import record

    rec = record.read(path)
    values = {"t": rec.data["t"]}
    units = {"t": "s"}
    for col, arr in rec.data.items():
        for prefix in ("in.", "truth."):
            if col.startswith(prefix):
                name = col[len(prefix) :]
                key = name if prefix == "in." else f"truth.{name}"
                values[key] = arr
                units[key] = rec.units.get(name, "")
    return Columns(values, units)


def trace_from_log(
    log: LogSource, spec: EstimatorSpec, sample_time: float, duration: float
) -> Trace:
    inputs = {s.name: s for s in spec.inputs}
    outputs = {s.name: s for s in spec.outputs}
    # A recording maps by name on its own; other logs need every input mapped.
    columns = {n: log.columns.get(n, n) for n in inputs}
    truths = dict(log.truth)
    if log.format == "vehil":
        for n in outputs:
            truths.setdefault(n, f"truth.{n}")
    if log.format == "csv":
        cols = read_csv(log.path)
    elif log.format == "mdf4":
        cols = read_mdf4(log.path, [*columns.values(), *truths.values()])
    else:
        cols = read_recording(log.path)
        truths = {n: c for n, c in truths.items() if c in cols.values}

    def column(name: str, unit: str, role: str) -> tuple[np.ndarray, np.ndarray]:
        if name not in cols.values:
            known = ", ".join(n for n in cols.values if not n.endswith("@t"))
            raise LogError(f"{log.path}: no column {name!r} for {role}; columns: {known}")
        have = cols.units.get(name, "")
        if have and unit and have != unit:
            raise LogError(f"{log.path}: column {name!r} is in {have!r}; {role} needs {unit!r}")
        x = cols.values[name]
        bad = np.flatnonzero(~np.isfinite(x))
        if len(bad):
            raise LogError(
                f"{log.path}: {cols.place(bad[0], name)}: {x[bad[0]]} is not a finite number "
                f"({len(bad)} such values in the column): clean the log or drop those rows"
            )
        time_name = f"{name}@t" if f"{name}@t" in cols.values else log.time
        t = cols.values.get(time_name)
        if t is None:
            raise LogError(f"{log.path}: no time column {log.time!r} (set [log] time = ...)")
        if len(t) < 2:
            raise LogError(f"{log.path}: column {name!r} has {len(t)} samples; it needs two")
        back = np.flatnonzero(np.diff(t) <= 0)
        if len(back):
            i = back[0] + 1
            shown = log.time if time_name == log.time else f"{name}'s time stamps"
            raise LogError(
                f"{log.path}: {cols.place(i, shown)}: time {t[i]:g} does not increase on "
                f"{t[i - 1]:g} before it; time must increase strictly"
            )
        return t, x

    t0 = math.inf
    t_end = -math.inf
    picked: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for n, c in columns.items():
        picked[n] = column(c, inputs[n].unit, f"input {n}")
    for n, c in truths.items():
        picked[f"truth.{n}"] = column(c, outputs[n].unit, f"the truth of {n}")
    for t, _ in picked.values():
        t0, t_end = min(t0, t[0]), max(t_end, t[-1])
    n_samples = int(math.floor((min(t_end - t0, duration)) / sample_time + 1e-9)) + 1
    grid = t0 + np.arange(n_samples) * sample_time
    on_grid = {k: np.interp(grid, t, x) for k, (t, x) in picked.items()}
    return Trace(
        t=grid - t0,
        signals={n: on_grid[n] for n in columns},
        truth={n: on_grid[f"truth.{n}"] for n in truths},
        units={**{n: s.unit for n, s in inputs.items()}, **{n: s.unit for n, s in outputs.items()}},
    )
