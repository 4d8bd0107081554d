"""What `vehil estimators` and `vehil plants` list: each estimator's and plant's signals,
parameters, units, ranges and Q formats, as tables for people and as data for programs."""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

from rich.markup import escape
from rich.table import Table

from vehil.estimators import EstimatorSpec
from vehil.plants.base import PlantSpec
from vehil.spec import Param, Signal


def q_format(s: Signal) -> str:
    """Q(31-q).q: the integer and fractional bits of the signed 32-bit value in FIXED."""
    return f"Q{31 - s.q}.{s.q}"


def _bound(x: float) -> float | None:
    return x if math.isfinite(x) else None


def signal_data(s: Signal) -> dict[str, Any]:
    lo, hi = s.fixed_range
    return {
        "name": s.name,
        "unit": s.unit,
        "q": s.q,
        "q_format": q_format(s),
        "fixed_range": [lo, hi],
        "doc": s.doc,
    }


def param_data(p: Param) -> dict[str, Any]:
    return {**signal_data(p), "default": p.default, "lo": _bound(p.lo), "hi": _bound(p.hi)}


def estimator_data(spec: EstimatorSpec) -> dict[str, Any]:
    return {
        "name": spec.name,
        "c_id": spec.c_id,
        "title": spec.title,
        "modes": list(spec.modes),
        "paper": spec.paper,
        "delay": spec.delay,
        "inputs": [signal_data(s) for s in spec.inputs],
        "outputs": [signal_data(s) for s in spec.outputs],
        "params": [param_data(p) for p in spec.params],
        "rules": [(r.__doc__ or r.__name__).strip() for r in spec.rules],
        "budget_cycles": dict(spec.budget),
    }


def plant_data(plant: PlantSpec) -> dict[str, Any]:
    return {
        "name": plant.name,
        "title": plant.title,
        "signals": [{"name": s.name, "unit": s.unit, "doc": s.doc} for s in plant.signals],
        "truth": [{"name": s.name, "unit": s.unit, "doc": s.doc} for s in plant.truth],
        "params": [
            {
                "name": p.name,
                "unit": p.unit,
                "default": p.default,
                "lo": _bound(p.lo),
                "hi": _bound(p.hi),
                "doc": p.doc,
            }
            for p in plant.params
        ],
        "closed_loop": plant.loop is not None,
        "feedback": list(plant.feedback),
    }


def _row(t: Table, *cells: str) -> None:
    """A row of plain text: units such as [m/s^2] are not markup."""
    t.add_row(*(escape(c) for c in cells))


def _signals(signals: Iterable[Signal], fixed: bool) -> str:
    return ", ".join(f"{s.name} [{s.unit}]" + (f" {q_format(s)}" if fixed else "") for s in signals)


def estimators_table(specs: Iterable[EstimatorSpec]) -> Table:
    t = Table(title="estimators (vehil estimators NAME: one in full)")
    for col in ("name", "C id", "modes", "inputs", "outputs", "params", "title"):
        t.add_column(col)
    for s in specs:
        fixed = "FIXED" in s.modes
        _row(
            t,
            s.name,
            str(s.c_id),
            " ".join(s.modes),
            _signals(s.inputs, fixed),
            _signals(s.outputs, fixed),
            str(len(s.params)),
            s.title,
        )
    return t


def _range(p: Param) -> str:
    return f"[{p.lo:g}, {p.hi:g}]"


def estimator_tables(spec: EstimatorSpec) -> list[Table]:
    fixed = "FIXED" in spec.modes
    q_cols = ("Q format (FIXED)", "FIXED range") if fixed else ()
    tables = []
    for what, signals in (("inputs", spec.inputs), ("outputs", spec.outputs)):
        t = Table(title=f"{spec.name} {what} ({' '.join(spec.modes)})")
        for col in ("#", "name", "unit", *q_cols, "meaning"):
            t.add_column(col)
        for i, s in enumerate(signals):
            q = (q_format(s), f"±{s.fixed_range[1]:.6g}") if fixed else ()
            _row(t, str(i), s.name, s.unit, *q, s.doc)
        tables.append(t)
    rules = "; ".join(estimator_data(spec)["rules"])
    t = Table(
        title=f"{spec.name} parameters (CONFIG order)", caption=f"and: {rules}" if rules else None
    )
    for col in ("#", "name", "unit", "default", "range", *q_cols[:1], "meaning"):
        t.add_column(col)
    for i, p in enumerate(spec.params):
        q_cell = (q_format(p),) if fixed else ()
        _row(t, str(i), p.name, p.unit, f"{p.default:g}", _range(p), *q_cell, p.doc)
    tables.append(t)
    return tables


def plants_table(plants: Iterable[PlantSpec]) -> Table:
    t = Table(title="plants (vehil plants NAME: one in full)")
    for col in ("name", "signals (measured)", "truth", "params", "loop", "title"):
        t.add_column(col)
    for p in plants:
        _row(
            t,
            p.name,
            _signals(p.signals, False),
            _signals(p.truth, False),
            str(len(p.params)),
            "closed" if p.loop else "open",
            p.title,
        )
    return t


def plant_tables(plant: PlantSpec) -> list[Table]:
    tables = []
    for what, signals in (("signals (measured)", plant.signals), ("truth", plant.truth)):
        t = Table(title=f"{plant.name} {what}")
        for col in ("name", "unit", "meaning"):
            t.add_column(col)
        for s in signals:
            _row(t, s.name, s.unit, s.doc)
        tables.append(t)
    t = Table(title=f"{plant.name} parameters")
    for col in ("name", "unit", "default", "range", "meaning"):
        t.add_column(col)
    for p in plant.params:
        _row(t, p.name, p.unit, f"{p.default:g}", _range(p), p.doc)
    tables.append(t)
    return tables
