"""A plant is the ground truth: it simulates a vehicle and its sensors.

An open-loop plant returns the whole drive at once (vectorised, seeded): the
time base, the measured signals an estimator takes as inputs, and the true
values of what estimators estimate. Names are the estimators' signal names, so
the runner wires plant to estimator by name (a scenario can rename).

A plant that can also close the loop gives a `loop` factory: a LoopPlant the
runner steps one sample at a time, applying the board's outputs named in
`feedback` (an actuator force, say) before the next sample.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from vehil.estimators.base import Param, Signal, resolve_params


@dataclass
class Trace:
    """A drive, sampled at the estimator's rate: t[k] and each signal's value at t[k]."""

    t: np.ndarray
    signals: dict[str, np.ndarray]
    truth: dict[str, np.ndarray]
    units: dict[str, str] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.t)


class LoopPlant(Protocol):
    """A plant in a closed loop, one sample time per apply()."""

    def measure(self) -> tuple[float, dict[str, float], dict[str, float]]:
        """t, the measured signals and the true values at the current sample."""
        ...

    def apply(self, outputs: Mapping[str, float]) -> None:
        """Acts on the estimator's outputs for this sample, then advances one sample time."""
        ...


@dataclass(frozen=True)
class PlantSpec:
    name: str
    title: str
    params: tuple[Param, ...]
    signals: tuple[Signal, ...]  # measured: what an estimator may take as input
    truth: tuple[Signal, ...]  # true values an estimator's outputs are compared with
    simulate: Callable[[Mapping[str, float], float, float, int], Trace]
    doc: str = ""
    loop: Callable[[Mapping[str, float], float, int], LoopPlant] | None = None  # (params, T, seed)
    feedback: tuple[str, ...] = ()  # estimator outputs the loop plant acts on

    def param_values(self, given: Mapping[str, float]) -> dict[str, float]:
        return resolve_params(f"plant {self.name}", self.params, given)

    def start_loop(self, params: Mapping[str, float], T: float, seed: int) -> LoopPlant:
        if self.loop is None:
            raise ValueError(f"plant {self.name} cannot close a loop")
        return self.loop(self.param_values(params), T, seed)

    def run(self, params: Mapping[str, float], duration: float, T: float, seed: int) -> Trace:
        trace = self.simulate(self.param_values(params), duration, T, seed)
        trace.units = {s.name: s.unit for s in (*self.signals, *self.truth)}
        return trace
