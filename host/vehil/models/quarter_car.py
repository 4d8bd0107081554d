"""The nonlinear quarter car of seed 003 (eqs. 1-3), shared by its plant, observers and controller.

States x = [x_s, ẋ_s, x_us, ẋ_us] from static equilibrium; Δx = x_s - x_us (extension
positive). u follows eqs. (4)-(5): +u/m_s on the body, -u/m_us on the wheel (eq. (1) prints the
opposite sign; docs/estimators/kfui.md). The damper is
the literal square c1 Δẋ + c2 Δẋ² by default (sign-preserving c2 Δẋ|Δẋ| behind a flag).
The truth may add strut Coulomb friction (smoothed by tanh) and tire lift-off; the
observers' nominal model has neither.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from vehil.spec import Param

G = 9.81


@dataclass(frozen=True)
class QuarterCar:
    """Table 1 by default. `friction` (N) and `lift_off` are truth-only extras."""

    m_s: float = 290.0
    m_us: float = 59.0
    k1: float = 12_394.0
    k2: float = -73_696.0
    k3: float = 3_170_400.0
    c1: float = 1_000.0
    c2: float = 500.0
    k_us: float = 190_000.0
    friction: float = 0.0
    friction_v: float = 0.01  # m/s: tanh smoothing of the Coulomb friction
    sign_preserving: bool = False
    lift_off: bool = False
    damper_hold: bool = False  # the literal damper held at its peak compression force

    @property
    def d1(self) -> float:
        return self.k_us / self.m_us

    @property
    def tire_static(self) -> float:
        """The tire's static deflection (m): beyond it the wheel would pull on the road."""
        return (self.m_s + self.m_us) * G / self.k_us

    def spring(self, dx: float) -> float:
        """f_s, eq. (2)."""
        return dx * (self.k1 + dx * (self.k2 + self.k3 * dx))

    def held(self, dv: float) -> float:
        """The rate the literal damper acts at: with damper_hold it keeps its peak
        compression force (c1 + 2 c2 Δẋ = 0) past Δẋ = -c1 / 2c2 instead of weakening
        and, past -c1 / c2, pushing."""
        if self.damper_hold and not self.sign_preserving and self.c2 > 0.0:
            return max(dv, -self.c1 / (2.0 * self.c2))
        return dv

    def damper(self, dv: float) -> float:
        """f_d, eq. (2): literal square unless sign_preserving."""
        dh = self.held(dv)
        sq = dv * abs(dv) if self.sign_preserving else dh * dh
        f = self.c1 * dh + self.c2 * sq
        if self.friction:
            f += self.friction * math.tanh(dv / self.friction_v)
        return f

    def strut(self, x: np.ndarray | list[float]) -> float:
        """f_s + f_d (+ friction): the force the strut pulls the body down and the wheel up with."""
        return self.spring(x[0] - x[2]) + self.damper(x[1] - x[3])

    def tire(self, x_us: float, x_r: float) -> float:
        """f_st, eq. (3); with lift_off the tire cannot pull the wheel down past its preload."""
        f = self.k_us * (x_us - x_r)
        if self.lift_off:
            f = min(f, (self.m_s + self.m_us) * G)
        return f

    def f1(self, x: np.ndarray | list[float]) -> float:
        """ẍ_s without the u term, eq. (7)."""
        return -self.strut(x) / self.m_s

    def f2(self, x: np.ndarray | list[float]) -> float:
        """ẍ_us without the road and u terms, eq. (8) (f2 = (f_s + f_d - k_us x_us)/m_us)."""
        return (self.strut(x) - self.k_us * x[2]) / self.m_us

    def accelerations(
        self, x: np.ndarray | list[float], u: float, x_r: float
    ) -> tuple[float, float]:
        fs = self.strut(x)
        return (-fs + u) / self.m_s, (fs - self.tire(x[2], x_r) - u) / self.m_us

    def deriv(self, x: np.ndarray | list[float], u: float, x_r: float) -> list[float]:
        a_s, a_us = self.accelerations(x, u, x_r)
        return [x[1], a_s, x[3], a_us]

    def road_from(self, x: np.ndarray | list[float], a_us: float, u: float) -> float:
        """x_r that makes m_us ẍ_us = f_s + f_d - k_us (x_us - x_r) - u hold (eqs. 1, 3)."""
        return x[2] + (self.m_us * a_us - self.strut(x) + u) / self.k_us

    def jacobian(self, x: np.ndarray | list[float]) -> np.ndarray:
        """∂[ẋ1..ẋ4]/∂x of the nominal model (eq. 37), the road and u held."""
        dx, dv = x[0] - x[2], x[1] - x[3]
        ks = self.k1 + 2 * self.k2 * dx + 3 * self.k3 * dx * dx
        dd = 2 * self.c2 * (abs(dv) if self.sign_preserving else self.held(dv))
        cs = self.c1 + dd
        ms, mu = self.m_s, self.m_us
        return np.array(
            [
                [0.0, 1.0, 0.0, 0.0],
                [-ks / ms, -cs / ms, ks / ms, cs / ms],
                [0.0, 0.0, 0.0, 1.0],
                [ks / mu, cs / mu, (-ks - self.k_us) / mu, -cs / mu],
            ]
        )

    def rk4(self, x: list[float], u: float, r0: float, r1: float, h: float) -> list[float]:
        """One RK4 step of h with u held and the road linear from r0 to r1."""
        rm = 0.5 * (r0 + r1)
        k1 = self.deriv(x, u, r0)
        k2 = self.deriv([x[i] + 0.5 * h * k1[i] for i in range(4)], u, rm)
        k3 = self.deriv([x[i] + 0.5 * h * k2[i] for i in range(4)], u, rm)
        k4 = self.deriv([x[i] + h * k3[i] for i in range(4)], u, r1)
        return [x[i] + h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]) for i in range(4)]


NOMINAL = QuarterCar()

# Table 1 as estimator parameters: the observers' and the controller's nominal model.
MODEL_PARAMS = ("m_s", "m_us", "k1", "k2", "k3", "c1", "c2", "k_us")


def nominal(p: Mapping[str, float]) -> QuarterCar:
    """The nominal model from an estimator's parameters (Table 1 unless overridden)."""
    changes: dict[str, Any] = {k: float(p[k]) for k in MODEL_PARAMS if k in p}
    return replace(NOMINAL, **changes)


def model_params() -> tuple[Param, ...]:
    """Table 1 as estimator parameters (Q formats sized for the fixed-point build)."""
    n = NOMINAL
    return (
        Param("m_s", "kg", q=16, default=n.m_s, lo=50, hi=2000, doc="nominal sprung mass"),
        Param("m_us", "kg", q=16, default=n.m_us, lo=35, hi=500, doc="nominal unsprung mass"),
        Param("k1", "N/m", q=8, default=n.k1, lo=0, hi=1e6, doc="spring, linear"),
        Param("k2", "N/m^2", q=8, default=n.k2, lo=-5e6, hi=5e6, doc="spring, quadratic"),
        Param("k3", "N/m^3", q=8, default=n.k3, lo=-8e6, hi=8e6, doc="spring, cubic"),
        Param("c1", "N s/m", q=16, default=n.c1, lo=0, hi=2e4, doc="damper, linear"),
        Param("c2", "N s^2/m^2", q=16, default=n.c2, lo=-2e4, hi=2e4, doc="damper, quadratic"),
        Param("k_us", "N/m", q=8, default=n.k_us, lo=1e4, hi=2e6, doc="tire stiffness"),
    )
