"""A noisy sine: the smallest plant that exercises run, record, replay and report.

Closed loop, the sine is the set point of a first-order lag whose feedback is the
board's output `y`: x' = (A sin(wt) + offset - y) / tau. Through passthrough the
loop tracks the sine; a board that returned anything else would steer it off.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping

import numpy as np

from vehil.plants import register
from vehil.plants.base import PlantSpec, Trace, joined
from vehil.spec import Param, Signal


def _stream(
    p: Mapping[str, float], duration: float, T: float, seed: int, chunk: int
) -> Iterator[Trace]:
    """The drive in chunks: one noise generator drawn in order gives the same samples as
    one draw of the whole length."""
    n = int(round(duration / T))
    rng = np.random.default_rng(seed)
    for k0 in range(0, n, chunk):
        t = np.arange(k0, min(n, k0 + chunk)) * T
        clean = p["amplitude"] * np.sin(2 * np.pi * p["frequency"] * t) + p["offset"]
        noise = rng.normal(0.0, p["noise_std"], len(t))
        yield Trace(t=t, signals={"y": clean + noise}, truth={"y": clean})


class _Loop:
    def __init__(self, p: Mapping[str, float], T: float, seed: int):
        self.p, self.T = p, T
        self.k = 0
        self.x = p["offset"]
        self.rng = np.random.default_rng(seed)

    def _setpoint(self) -> float:
        return self.p["amplitude"] * np.sin(2 * np.pi * self.p["frequency"] * self.k * self.T)

    def measure(self) -> tuple[float, dict[str, float], dict[str, float]]:
        y = self.x + self.rng.normal(0.0, self.p["noise_std"])
        return self.k * self.T, {"y": y}, {"y": self.x}

    def apply(self, outputs: Mapping[str, float]) -> None:
        target = self._setpoint() + self.p["offset"]
        self.x += self.T / self.p["tau"] * (target - outputs["y"])
        self.k += 1


SPEC = register(
    PlantSpec(
        name="noisy_sine",
        title="Sine with white Gaussian measurement noise",
        params=(
            Param("amplitude", "1", default=1.0, lo=0.0, hi=1e3),
            Param("frequency", "Hz", default=0.5, lo=0.0, hi=1e3),
            Param("offset", "1", default=0.0, lo=-1e3, hi=1e3),
            Param("noise_std", "1", default=0.05, lo=0.0, hi=1e3),
            Param("tau", "s", default=0.1, lo=1e-3, hi=1e3, doc="closed loop: lag time constant"),
        ),
        signals=(Signal("y", "1", doc="measured: sine plus noise"),),
        truth=(Signal("y", "1", doc="the sine without noise"),),
        simulate=joined(_stream),
        stream=_stream,
        loop=_Loop,
        feedback=("y",),
    )
)
