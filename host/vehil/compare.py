"""Metrics: how far the board is from the float64 reference and from the truth.

One evaluation serves a fresh run and a recording read back, so a report and a
regression check of old runs use the same numbers.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vehil.protocol.schema import SCHEMA
from vehil.scenario import Tolerance


@dataclass
class Series:
    """A run's columns, wherever they came from."""

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


def _err_stats(err: np.ndarray) -> dict[str, Any]:
    if len(err) == 0:
        return {"rmse": None, "max_abs": None, "worst_k": None}
    a = np.abs(err)
    return {
        "rmse": float(np.sqrt(np.mean(err**2))),
        "max_abs": float(a.max()),
        "worst_k": int(a.argmax()),
    }


def evaluate(s: Series) -> dict[str, Any]:
    n = len(s.board)
    outputs: dict[str, Any] = {}
    all_pass = True
    for j, name in enumerate(s.names):
        tol = s.tolerances.get(name, Tolerance())
        b, r = s.board[:, j], s.reference[:, j]
        vs_ref = _err_stats(b - r)
        over = (np.abs(b - r) > tol.abs + tol.rel * np.abs(r)) & (s.t[:n] >= tol.from_s)
        checked = name in s.tolerances
        vs_ref["outside_tolerance"] = int(over.sum())
        vs_ref["pass"] = (not checked) or not over.any()
        entry: dict[str, Any] = {
            "unit": s.units.get(name, ""),
            "tolerance": vars(tol) if checked else None,
            "reference": vs_ref,
        }
        if name in s.truth:
            vt = _err_stats(b - s.truth[name][:n])
            vt["reference_rmse"] = _err_stats(r - s.truth[name][:n])["rmse"]
            vt["pass"] = tol.truth_rms is None or (
                vt["rmse"] is not None and vt["rmse"] <= tol.truth_rms
            )
            entry["truth"] = vt
        if tol.bit_exact and s.native is not None:
            mism = int(np.sum(b != s.native[:n, j]))
            entry["bit_exact"] = {"mismatches": mism, "pass": mism == 0}
        all_pass &= all(v.get("pass", True) for v in entry.values() if isinstance(v, dict))
        outputs[name] = entry
    flags = {name: int(np.sum((s.status & bit) != 0)) for name, bit in SCHEMA.status.items()}

    def pct(x: np.ndarray, q: float) -> float | None:
        return float(np.percentile(x, q)) if len(x) else None

    return {
        "samples": n,
        "outputs": outputs,
        "cycles": {
            "min": int(s.cycles.min()) if n else None,
            "median": pct(s.cycles, 50),
            "max": int(s.cycles.max()) if n else None,
        },
        "rtt_ms": {
            "p50": pct(s.rtt_s * 1e3, 50),
            "p99": pct(s.rtt_s * 1e3, 99),
            "max": float(s.rtt_s.max() * 1e3) if n else None,
        },
        "late": int(s.late.sum()),
        "stack_bytes": s.stack_bytes,
        "status": flags,
        "pass": bool(all_pass and n > 0),
    }


def diff_runs(a: Series, b: Series) -> dict[str, Any]:
    """Board output of run B against run A, sample by sample, over their common length."""
    n = min(len(a.board), len(b.board))
    out: dict[str, Any] = {"samples": n, "lengths": [len(a.board), len(b.board)], "outputs": {}}
    for j, name in enumerate(a.names):
        if name not in b.names:
            continue
        x, y = a.board[:n, j], b.board[:n, b.names.index(name)]
        d = y - x
        differ = np.flatnonzero(x != y)
        out["outputs"][name] = {
            "identical": len(differ) == 0,
            "differing_samples": int(len(differ)),
            "first_difference_k": int(differ[0]) if len(differ) else None,
            "max_abs": float(np.max(np.abs(d))) if n else 0.0,
        }
    same_inputs = bool(np.array_equal(a.t[:n], b.t[:n]))
    out["same_time_base"] = same_inputs
    out["identical"] = (
        a.names == b.names
        and len(a.board) == len(b.board)
        and all(o["identical"] for o in out["outputs"].values())
    )
    cyc = {}
    for label, s in (("a", a), ("b", b)):
        cyc[label] = float(np.median(s.cycles)) if len(s.cycles) else None
    out["cycles_median"] = cyc
    return out


def series_from_recording(rec: Any) -> Series:
    """A vehil.record.Recording as a Series (tolerances as recorded with the run)."""
    d = rec.data
    names = rec.outputs
    tolerances = {n: Tolerance(**t) for n, t in rec.header.get("tolerances", {}).items()}
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
        stack_bytes=(rec.end or {}).get("stack_bytes"),
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
    )
