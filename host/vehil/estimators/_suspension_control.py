"""Seed 003's nonlinear pointwise-predictive suspension controller, reconstructed: the paper
(Sec. 6.2) names a pointwise index of predicted responses whose weights keep the limits,
but gives neither the law nor the weights nor the horizon (docs/estimators/eso.md).

Each output is predicted over the horizon h by a Taylor series up to the order in which u
appears, on the model the observer updated (ẍ_s = F̂1 + u/m_s, ẍ_us = F̂2 - u/m_us, the
road's rate and acceleration taken as zero):
    z_a = F̂1 + u/m_s                                        (comfort, now)
    z_sd(t+h) = Δx + hΔẋ + h²/2 (F̂1 - F̂2 + u(1/m_s + 1/m_us))  (suspension deflection)
    z_td(t+h) = (x̂_us - x̂_r) + h ẋ̂_us + h²/2 (F̂2 - u/m_us)      (tire deflection)
    z_v(t+h)  = ẋ̂_s + h (F̂1 + u/m_s)                           (body velocity)
J(u) = ½ [ρ_a z_a² + ρ_sd z_sd² + ρ_td z_td² + ρ_v z_v² + r u²] is quadratic in u, so
u* = -Σ ρ_i a_i b_i / (r + Σ ρ_i b_i²), then a safety saturation at ±u_max. The weights
keep the limits (the paper's claim); whether the saturation ever acts is logged.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from vehil.estimators.base import Param
from vehil.models.quarter_car import QuarterCar

PARAMS = (
    Param("active", "1", q=0, default=1, lo=0, hi=1, doc="0: passive (u = 0)"),
    Param("rho_a", "1", q=16, default=1.0, lo=0, hi=1e4, doc="weight: body acceleration"),
    Param("rho_sd", "1", q=8, default=2.0e5, lo=0, hi=8e6, doc="weight: suspension deflection"),
    Param("rho_td", "1", q=8, default=0.0, lo=0, hi=8e6, doc="weight: tire deflection"),
    Param("rho_v", "1", q=8, default=2.0e4, lo=0, hi=8e6, doc="weight: body velocity"),
    Param("r_u", "1", q=40, default=1.0e-7, lo=1e-10, hi=1e-3, doc="weight: force"),
    Param("horizon", "s", q=30, default=0.02, lo=0.001, hi=1.0, doc="prediction horizon h"),
    Param("u_max", "N", q=16, default=1500.0, lo=0, hi=20_000, doc="saturation"),
)


@dataclass
class Prediction:
    """Each output as a + b u (a from the estimates, b from the model)."""

    a: np.ndarray
    b: np.ndarray
    rho: np.ndarray


class PredictiveController:
    def __init__(self, model: QuarterCar, p: Mapping[str, float]):
        self.m = model
        self.p = p
        h = p["horizon"]
        ms, mu = model.m_s, model.m_us
        self.b = np.array([1 / ms, h * h / 2 * (1 / ms + 1 / mu), -h * h / 2 / mu, h / ms])
        self.rho = np.array([p["rho_a"], p["rho_sd"], p["rho_td"], p["rho_v"]])

    def predict(self, x: np.ndarray, F1: float, F2: float, x_r: float) -> Prediction:
        h = self.p["horizon"]
        a = np.array(
            [
                F1,
                (x[0] - x[2]) + h * (x[1] - x[3]) + h * h / 2 * (F1 - F2),
                (x[2] - x_r) + h * x[3] + h * h / 2 * F2,
                x[1] + h * F1,
            ]
        )
        return Prediction(a, self.b, self.rho)

    def cost(self, u: float, x: np.ndarray, F1: float, F2: float, x_r: float) -> float:
        pr = self.predict(x, F1, F2, x_r)
        z = pr.a + pr.b * u
        return 0.5 * float(np.sum(pr.rho * z * z) + self.p["r_u"] * u * u)

    def law(self, x: np.ndarray, F1: float, F2: float, x_r: float) -> tuple[float, float]:
        """(u applied, u* before the saturation)."""
        if self.p["active"] < 0.5:
            return 0.0, 0.0
        pr = self.predict(x, F1, F2, x_r)
        u = -float(np.sum(pr.rho * pr.a * pr.b)) / (self.p["r_u"] + float(np.sum(pr.rho * pr.b**2)))
        lim = self.p["u_max"]
        return min(max(u, -lim), lim), u
