"""Perturbations of a plant's parameters for a Monte Carlo sweep: declared, checked, drawn.

A perturbation says how one plant parameter varies from drive to drive, uniformly:
`{rel = 0.15}` (nominal × (1 ± 0.15)), `{abs = 100}` (nominal ± 100), `{lo = 1200,
hi = 2000}`, or `{values = [0, 2, 4]}` (one of them). The nominal is the scenario's
value, else the plant's default. Every value a perturbation can draw must lie in the
parameter's range, so a bad envelope is refused before any drive runs.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vehil.spec import Param


@dataclass(frozen=True)
class Perturbation:
    name: str
    unit: str
    lo: float
    hi: float
    values: tuple[float, ...] = ()  # a choice among these instead of [lo, hi]
    how: str = ""  # as declared, for the report

    def draw(self, rng: np.random.Generator) -> float:
        if self.values:
            return float(self.values[int(rng.integers(len(self.values)))])
        return float(rng.uniform(self.lo, self.hi))


def _number(owner: str, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{owner}: {key} must be a number, got {value!r}")
    return float(value)


def declare(
    name: str,
    table: Mapping[str, Any],
    params: Sequence[Param],
    nominal: Mapping[str, Any],
    plant: str,
) -> Perturbation:
    """One perturbation from its table; raises ValueError naming the parameter and what
    is wrong (unknown name or key, or an envelope outside the plant's range)."""
    known = {p.name: p for p in params}
    if name not in known:
        raise ValueError(
            f"sweep.{name}: plant {plant} has no parameter {name} (it has: {', '.join(known)})"
        )
    p = known[name]
    owner = f"sweep.{name}"
    if not isinstance(table, Mapping):
        raise ValueError(f"{owner}: give a table, e.g. {{rel = 0.1}}; got {table!r}")
    keys = set(table)
    forms = [{"rel"}, {"abs"}, {"lo", "hi"}, {"values"}]
    if keys not in forms:
        raise ValueError(
            f"{owner}: give exactly one of {{rel = R}}, {{abs = A}}, {{lo = L, hi = H}} or "
            f"{{values = [...]}}; got keys {', '.join(sorted(keys)) or 'none'}"
        )
    centre = float(nominal[name])
    values: tuple[float, ...] = ()
    if "rel" in table:
        r = _number(owner, "rel", table["rel"])
        if r < 0:
            raise ValueError(f"{owner}: rel = {r:g} must be ≥ 0")
        lo, hi = sorted((centre * (1 - r), centre * (1 + r)))
        how = f"±{r:.0%} of {centre:g}"
    elif "abs" in table:
        a = _number(owner, "abs", table["abs"])
        if a < 0:
            raise ValueError(f"{owner}: abs = {a:g} must be ≥ 0")
        lo, hi = centre - a, centre + a
        how = f"{centre:g} ± {a:g}"
    elif "values" in table:
        raw = table["values"]
        if not isinstance(raw, list) or not raw:
            raise ValueError(f"{owner}: values must be a non-empty list, got {raw!r}")
        values = tuple(_number(owner, "values", v) for v in raw)
        lo, hi = min(values), max(values)
        how = "one of " + ", ".join(f"{v:g}" for v in values)
    else:
        lo, hi = _number(owner, "lo", table["lo"]), _number(owner, "hi", table["hi"])
        if lo > hi:
            raise ValueError(f"{owner}: lo = {lo:g} is above hi = {hi:g}")
        how = f"[{lo:g}, {hi:g}]"
    slack = 1e-9 * max(abs(lo), abs(hi), 1.0)  # rounding of nominal × (1 ± r) at a bound
    if lo < p.lo - slack or hi > p.hi + slack:
        raise ValueError(
            f"{owner} = {how} draws values in [{lo:g}, {hi:g}] {p.unit}, outside plant "
            f"{plant}'s range for {name}, [{p.lo:g}, {p.hi:g}] {p.unit}: narrow it"
        )
    return Perturbation(name, p.unit, max(lo, p.lo), min(hi, p.hi), values, how)


def parse_option(text: str) -> tuple[str, dict[str, Any]]:
    """`--vary NAME:rel=0.15`, `NAME:abs=100`, `NAME:lo=1200,hi=2000`, `NAME:values=0/2/4`."""
    name, sep, rest = text.partition(":")
    if not sep or not name or not rest:
        raise ValueError(
            f"--vary {text!r}: write NAME:rel=R, NAME:abs=A, NAME:lo=L,hi=H or NAME:values=A/B/C"
        )
    table: dict[str, Any] = {}
    for item in rest.split(","):
        key, eq, value = item.partition("=")
        try:
            if key == "values":
                table[key] = [float(v) for v in value.split("/")]
            else:
                table[key] = float(value)
        except ValueError:
            raise ValueError(f"--vary {text!r}: {value!r} is not a number") from None
        if not eq:
            raise ValueError(f"--vary {text!r}: {item!r} needs KEY=VALUE")
    return name.strip(), table
