"""The vocabulary plants and estimators share: signals, parameters and their checking.

Both sides describe their inputs, outputs and parameters with these, and neither imports
the other (tests/unit/test_import_rule.py enforces it): a truth plant and an estimator
agree on names and units, not on code.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Self

INT32_RANGE = (-(2**31), 2**31 - 1)


@dataclass(frozen=True)
class Signal:
    """One input or output: its name, unit, fixed-point format and meaning."""

    name: str
    unit: str
    q: int = 16  # fractional bits in FIXED mode
    doc: str = ""

    @property
    def lsb(self) -> float:
        return 2.0**-self.q

    @property
    def fixed_range(self) -> tuple[float, float]:
        return INT32_RANGE[0] * self.lsb, INT32_RANGE[1] * self.lsb


@dataclass(frozen=True)
class Param(Signal):
    """A configuration value, with its default and the range the board accepts."""

    default: float = 0.0
    lo: float = -math.inf
    hi: float = math.inf

    def check(self, value: float) -> str | None:
        if not math.isfinite(value) or not self.lo <= value <= self.hi:
            unit = "" if self.unit in ("", "1") else f" {self.unit}"
            return f"{self.name} = {value:g}{unit} is outside [{self.lo:g}, {self.hi:g}]{unit}"
        return None


def resolve_params(
    owner: str, params: Sequence[Param], given: Mapping[str, float]
) -> dict[str, float]:
    """Defaults overridden by `given`; raises ValueError naming each unknown or bad one."""
    known = {p.name: p for p in params}
    unknown = sorted(set(given) - set(known))
    if unknown:
        raise ValueError(
            f"{owner} has no parameter {', '.join(unknown)} (it has: {', '.join(known) or 'none'})"
        )
    values = {p.name: float(given.get(p.name, p.default)) for p in params}
    problems = [m for p in params if (m := p.check(values[p.name]))]
    if problems:
        raise ValueError("; ".join(problems))
    return values


@dataclass(frozen=True)
class ParamRecord:
    """Resolved parameters as a typed record: subclasses declare float fields named
    like the parameters (a car's m, l_f, ...), and `of` fills them from a mapping."""

    @classmethod
    def of(cls, p: Mapping[str, float]) -> Self:
        return cls(**{f.name: float(p[f.name]) for f in fields(cls)})
