"""Tolerances from an error budget: how far a board's outputs may honestly stray from the
float64 reference, given the arithmetic it runs in, what the estimator amplifies and how
many steps it takes. README "Choosing tolerances" says how to use it.

A float32 board rounds every value it stores to 2^-24 of itself (its unit roundoff u); a
FIXED board rounds each to its Q format, here taken as a relative u = 2^-20 (Q formats
sized with ~2^11 of headroom over the value, as docs/estimators/*.md size them), and its
inputs to their Q format's LSB. What that does to an output is the estimator's business:
a leaky integrator forgets it, a high-pass with a pole near z = 1 piles it up over ~1/(1-p)
steps, a closed loop may feed it back. So the budget is measured, not guessed: the float64
reference is run again with every value it stores (each float or float array in the
object, that a step computes: not what it only copies, a filter's history) and every
input rounded by ±u at random each step, and the parameters once (the board stores them
in its own arithmetic too). The largest |output
difference| over a few such runs, from each tolerance's `from_s`, is the rounding's reach
on this drive: float32 rounding × amplification × step count, with no model of either.
The suggested tolerance is `safety` (default 4: a few runs see a few of the worst cases)
times that. A board outside it by far has a bug; one near it is rounding.

    vehil tolerances SCENARIO [--trials 4] [--safety 4] [--roundoff U] [--toml]
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from vehil.runner import Prepared, prepare
from vehil.scenario import Scenario

ROUNDOFF = {"F32": 2.0**-24, "FIXED": 2.0**-20}
SAFETY = 4.0


@dataclass(frozen=True)
class Budget:
    """One output's budget: the perturbed runs' largest |Δ| and the tolerance it suggests."""

    reach: float  # max |perturbed - float64| over the trials, from from_s
    tolerance: float  # safety × reach, two significant digits up
    shipped: float | None  # the scenario's own abs tolerance, if any


def _slots(obj: Any, seen: set[int]) -> Iterator[tuple[Any, str | int]]:
    """(container, key) of every float and float array an object holds, recursively
    (attributes, lists, tuples' members are not replaced: lists only)."""
    if id(obj) in seen:
        return
    seen.add(id(obj))
    items: Iterator[tuple[str | int, Any]]
    if isinstance(obj, list):
        items = iter(enumerate(obj))
    elif hasattr(obj, "__dict__") and not isinstance(obj, type):
        items = iter(vars(obj).items())
    else:
        return
    for key, value in items:
        if isinstance(value, float) or (isinstance(value, np.ndarray) and value.dtype.kind == "f"):
            yield obj, key
        elif isinstance(value, list) or hasattr(value, "__dict__"):
            yield from _slots(value, seen)


def _get(container: Any, key: str | int) -> Any:
    return container[key] if isinstance(key, int) else getattr(container, key)


def _set(container: Any, key: str | int, value: Any) -> None:
    if isinstance(key, int):
        container[key] = value
    else:
        setattr(container, key, value)


def _round(value: Any, u: float, rng: np.random.Generator) -> Any:
    if isinstance(value, np.ndarray):
        return value * (1.0 + u * rng.uniform(-1.0, 1.0, value.shape))
    return float(value) * (1.0 + u * rng.uniform(-1.0, 1.0))


def perturbed(prepared: Prepared, u: float, seed: int) -> np.ndarray:
    """The reference's outputs on the drive with its stores, inputs and parameters rounded
    by ±u each (a closed loop's inputs are the recorded ones: the loop is not re-closed)."""
    sc = prepared.scenario
    rng = np.random.default_rng(seed)
    params = {k: v if float(v).is_integer() else _round(v, u, rng) for k, v in sc.params.items()}
    ref = sc.estimator.reference(params)
    fixed = sc.mode == "FIXED"
    lsb = np.array([s.lsb for s in sc.estimator.inputs])
    out = np.empty_like(prepared.reference)
    for k, exact in enumerate(prepared.inputs):
        x = (
            exact + 0.5 * lsb * rng.uniform(-1.0, 1.0, exact.shape)
            if fixed
            else _round(exact, u, rng)
        )
        slots = list(_slots(ref, set()))
        before = [np.copy(_get(c, key)) for c, key in slots]
        out[k] = np.asarray(ref.step(x), dtype=float).reshape(-1)
        # A value the step only moved (a filter's history, the input kept for the next
        # step) is a copy, exact on the board too: only what it computed is rounded.
        known = np.concatenate([np.ravel(x), *(np.ravel(b) for b in before)])
        for (c, key), old in zip(slots, before, strict=True):
            new = _get(c, key)
            if np.array_equal(new, old):
                continue
            computed = ~np.isin(new, known)
            _set(c, key, np.where(computed, _round(new, u, rng), new) if computed.any() else new)
    return out


def _up2(x: float) -> float:
    """x rounded up to two significant digits."""
    if x <= 0 or not math.isfinite(x):
        return x
    e = math.floor(math.log10(x)) - 1
    return float(f"{math.ceil(x / 10.0**e)}e{e}")


def budget(
    sc: Scenario,
    trials: int = 4,
    safety: float = SAFETY,
    roundoff: float | None = None,
    prepared: Prepared | None = None,
) -> dict[str, Budget]:
    """Each output's budget on the scenario's drive."""
    prepared = prepared or prepare(sc)
    u = roundoff if roundoff is not None else ROUNDOFF[sc.mode]
    names = prepared.output_names
    reach = np.zeros(len(names))
    for i in range(trials):
        diff = np.abs(perturbed(prepared, u, sc.seed + 1000 + i) - prepared.reference)
        for j, name in enumerate(names):
            tol = sc.tolerances.get(name)
            k0 = max(round(tol.from_s / sc.sample_time), tol.from_samples) if tol else 0
            reach[j] = max(reach[j], float(np.nanmax(diff[k0:, j])) if len(diff) > k0 else 0.0)
    return {
        name: Budget(
            reach=float(reach[j]),
            tolerance=_up2(safety * float(reach[j])),
            shipped=sc.tolerances[name].abs if name in sc.tolerances else None,
        )
        for j, name in enumerate(names)
    }


def as_toml(budgets: Mapping[str, Budget]) -> str:
    """The budget as a scenario's [tolerance.*] tables."""
    return "\n".join(f"[tolerance.{n}]\nabs = {b.tolerance:.2g}" for n, b in budgets.items())
