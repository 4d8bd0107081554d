"""A noisy sine: the smallest plant that exercises run, record, replay and report."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from vehil.estimators.base import Param, Signal
from vehil.plants import register
from vehil.plants.base import PlantSpec, Trace


def _simulate(p: Mapping[str, float], duration: float, T: float, seed: int) -> Trace:
    t = np.arange(int(round(duration / T))) * T
    clean = p["amplitude"] * np.sin(2 * np.pi * p["frequency"] * t) + p["offset"]
    noise = np.random.default_rng(seed).normal(0.0, p["noise_std"], len(t))
    return Trace(t=t, signals={"y": clean + noise}, truth={"y": clean})


SPEC = register(
    PlantSpec(
        name="noisy_sine",
        title="Sine with white Gaussian measurement noise",
        params=(
            Param("amplitude", "1", default=1.0, lo=0.0, hi=1e3),
            Param("frequency", "Hz", default=0.5, lo=0.0, hi=1e3),
            Param("offset", "1", default=0.0, lo=-1e3, hi=1e3),
            Param("noise_std", "1", default=0.05, lo=0.0, hi=1e3),
        ),
        signals=(Signal("y", "1", doc="measured: sine plus noise"),),
        truth=(Signal("y", "1", doc="the sine without noise"),),
        simulate=_simulate,
    )
)
