"""Seed 003's extended state observer on the quarter car, and the board's whole ECU task.

Two 3-state observers (the paper's Sec. 4, eq. 12), one per subsystem, fed with the displacements
the conditioning chain integrates from the two accelerometers. Bandwidth
parameterisation: the error dynamics are (s + 1/ε)³.
- Variant A (literal, "total disturbance"): no model inside; β = 3/ε, 3/ε², 1/ε³;
  F̂1 = z3, F̂2 = z6 and x̂_r = x̂_us + (m_us F̂2 - f_s - f_d)/k_us (from F2 = f2 + d1 x_r),
  the strut force f_s + f_d from the nominal strut at x̂ (the paper), or, with
  `road_from` = 1, from the body's own equation m_s F1 = -(f_s + f_d), which needs no
  strut model (friction, a spring of another rate: docs/estimators/eso.md).
- `design` = 1 computes the gains for the discrete loop the board runs (Euler at T), its
  error poles at e^{-T/ε}: the paper's 3/ε, 3/ε², 1/ε³ place them only for T << ε.
- Variant B (model-assisted, "model updating"): the nominal strut's nonlinear terms
  f_nl = k2 Δx² + k3 Δx³ + c2 Δẋ² inside both observers; the linear strut terms and the
  tire are left to z3 and z6, so the error dynamics at equilibrium stay (s + 1/ε)³ with the
  same gains. (The whole model inside with the triple gains leaves a pole near
  -0.24 rad/s; gains placed per block for k1/m, c1/m leave the coupled pair at
  -0.3 ± 6.8j. Leaving out the terms that move the poles avoids both.)
- The no-updating baseline (reference only; the paper compares with it, Figs. 7-8, but
  does not define it): the full nominal model, extended states off;
  x̂_r by inverting the unsprung equation with the filtered acceleration.
All integrate with Euler at T from the current measurement (ZOH); the baseline with ten
Euler sub-steps (its model holds the stiff tire). The B-vectors are physical (1/m_s,
-1/m_us), not the printed unit entries.

The `eso` spec is what the board runs each sample: conditioning + ESO (A or B) + the
predictive controller, from the two accelerations to the estimates, x̂_r and u.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import NamedTuple, Protocol

import numpy as np

from vehil.estimators import register
from vehil.estimators._accel_conditioning import Channel, band_limit
from vehil.estimators._accel_conditioning import params as conditioning_params
from vehil.estimators._suspension_control import PARAMS as CONTROL_PARAMS
from vehil.estimators._suspension_control import PredictiveController
from vehil.estimators.base import EstimatorSpec, Param, Signal
from vehil.models.quarter_car import QuarterCar, model_params, nominal

VARIANT_A, VARIANT_B = 0, 1
DESIGN_PAPER, DESIGN_DISCRETE = 0, 1
ROAD_FROM_MODEL, ROAD_FROM_BODY = 0, 1


def gains(eps: float, T: float = 0.0, design: int = 0) -> np.ndarray:
    """[β1..β6] = 3w, 3w², w³ for both observers. Design 0 (the paper's gain theorem, Sec. 4):
    w = 1/ε, error poles at -1/ε for the continuous observer, which Euler at T only
    approximates.
    Design 1: w = (1 - e^{-T/ε})/T, which puts the Euler loop's own error poles (the
    step's z += T ż) at e^{-T/ε}, triple, for any T/ε: docs/estimators/eso.md."""
    w = (1.0 - math.exp(-T / eps)) / T if design == DESIGN_DISCRETE else 1.0 / eps
    return np.array([3 * w, 3 * w * w, w**3] * 2)


def gains_fit_fixed(p: Mapping[str, float], mode: str) -> str | None:
    """The spec's rule, CONFIG's too: FIXED holds T β2 in Q20 and T β3 in Q16."""
    g = p["T"] * gains(p["eps"], p["T"], int(p["design"]))
    if mode == "FIXED" and (g[1] >= 2048 or g[2] >= 32768):
        return (
            f"eps = {p['eps']:g} s gives T β2 = {g[1]:.4g}, T β3 = {g[2]:.4g} at T = {p['T']:g} s: "
            "past FIXED's ±2048 and ±32768; a larger eps (or design 1)"
        )
    return None


def strut_nonlinear(m: QuarterCar, x: np.ndarray) -> float:
    """f_s + f_d less its linear part k1 Δx + c1 Δẋ: what variant B's model adds."""
    return m.strut(x) - m.k1 * (x[0] - x[2]) - m.c1 * (x[1] - x[3])


class Eso:
    """step(y_s, y_us, u_prev) with measured displacements -> z = [x̂_s, ẋ̂_s, ·, x̂_us, ẋ̂_us, ·]."""

    def __init__(self, p: Mapping[str, float]):
        self.m = nominal(p)
        self.T = p["T"]
        self.variant = int(p["variant"])
        self.beta = gains(p["eps"], self.T, int(p["design"]))
        self.road_from = int(p["road_from"])
        self.z = np.zeros(6)

    def step(self, y_s: float, y_us: float, u: float) -> np.ndarray:
        z, b, m = self.z, self.beta, self.m
        e1, e2 = y_s - z[0], y_us - z[3]
        fs = strut_nonlinear(m, z[[0, 1, 3, 4]]) if self.variant == VARIANT_B else 0.0
        dz = np.array(
            [
                z[1] + b[0] * e1,
                z[2] - fs / m.m_s + u / m.m_s + b[1] * e1,
                b[2] * e1,
                z[4] + b[3] * e2,
                z[5] + fs / m.m_us - u / m.m_us + b[4] * e2,
                b[5] * e2,
            ]
        )
        self.z = z + self.T * dz
        return self.z

    def update(self, m: Measured, u: float) -> None:
        self.step(m.y_s, m.y_us, u)

    def estimates(self) -> tuple[np.ndarray, float, float, float]:
        """(x̂ = [x_s, ẋ_s, x_us, ẋ_us], F̂1, F̂2, x̂_r): F̂ total, less the known u terms."""
        z, m = self.z, self.m
        x = z[[0, 1, 3, 4]]
        F1, F2 = z[2], z[5]
        if self.variant == VARIANT_B:
            fnl = strut_nonlinear(m, x)
            F1, F2 = F1 - fnl / m.m_s, F2 + fnl / m.m_us
        strut = -m.m_s * F1 if self.road_from == ROAD_FROM_BODY else m.strut(x)
        return x, F1, F2, x[2] + (m.m_us * F2 - strut) / m.k_us


class NoUpdate:
    """The "without model updating" baseline of the paper's Figs. 7-8, which it does not
    define: ours, as the module docstring says."""

    SUBSTEPS = 10

    def __init__(self, p: Mapping[str, float]):
        self.m = nominal(p)
        self.T = p["T"]
        self.beta = gains(p["eps"])
        self.x = np.zeros(4)
        self.x_r = 0.0

    def step(self, y_s: float, y_us: float, a_us: float, u: float) -> None:
        m, b = self.m, self.beta
        h = self.T / self.SUBSTEPS
        for _ in range(self.SUBSTEPS):
            x = self.x
            e1, e2 = y_s - x[0], y_us - x[2]
            self.x = x + h * np.array(
                [
                    x[1] + b[0] * e1,
                    m.f1(x) + u / m.m_s + b[1] * e1,
                    x[3] + b[3] * e2,
                    m.f2(x) - u / m.m_us + b[4] * e2,
                ]
            )
        self.x_r = m.road_from(self.x, a_us, u)

    def update(self, m: Measured, u: float) -> None:
        self.step(m.y_s, m.y_us, m.af_us, u)

    def estimates(self) -> tuple[np.ndarray, float, float, float]:
        m = self.m
        return self.x.copy(), m.f1(self.x), m.f2(self.x) + m.d1 * self.x_r, self.x_r


OUTPUTS = (
    Signal("x_s", "m", q=28, doc="x̂_s"),
    Signal("v_s", "m/s", q=24, doc="ẋ̂_s"),
    Signal("x_us", "m", q=28, doc="x̂_us"),
    Signal("v_us", "m/s", q=24, doc="ẋ̂_us"),
    Signal("F1", "m/s^2", q=20, doc="F̂1: body acceleration less u/m_s"),
    Signal("F2", "m/s^2", q=20, doc="F̂2: wheel acceleration plus u/m_us"),
    Signal("x_r", "m", q=28, doc="x̂_r, the road input"),
    Signal("u", "N", q=16, doc="actuator force (saturated at u_max)"),
)
INPUTS = (
    Signal("a_s", "m/s^2", q=16, doc="sprung-mass accelerometer"),
    Signal("a_us", "m/s^2", q=16, doc="unsprung-mass accelerometer"),
)
T_PARAM = Param("T", "s", q=30, default=0.01, lo=1e-4, hi=0.05, doc="sample time")


class Measured(NamedTuple):
    """One sample as the observers see it: raw and filtered accelerations, displacements."""

    a_s: float
    a_us: float
    af_s: float
    af_us: float
    y_s: float
    y_us: float


class Observer(Protocol):
    def update(self, m: Measured, u: float) -> None: ...

    def estimates(self) -> tuple[np.ndarray, float, float, float]: ...


class Ecu:
    """The board's task, float64: conditioning -> observer -> controller.
    step([a_s, a_us]) -> [x̂_s, ẋ̂_s, x̂_us, ẋ̂_us, F̂1, F̂2, x̂_r, u]; `u_raw` keeps u* before
    the saturation. The observer sees the u applied over the last sample."""

    def __init__(self, p: Mapping[str, float], observer: Observer | None = None):
        T = p["T"]
        self.ch = [Channel(T, p["f_hp"], p["f_lp"], p["f_post"]) for _ in range(2)]
        self.obs: Observer = observer if observer is not None else Eso(p)
        self.ctrl = PredictiveController(nominal(p), p)
        self.u = 0.0
        self.u_raw = 0.0

    def step(self, u: np.ndarray) -> np.ndarray:
        (af_s, _, y_s), (af_us, _, y_us) = (
            c.step(float(a)) for c, a in zip(self.ch, u, strict=True)
        )
        self.obs.update(Measured(float(u[0]), float(u[1]), af_s, af_us, y_s, y_us), self.u)
        x, F1, F2, x_r = self.obs.estimates()
        self.u, self.u_raw = self.ctrl.law(x, F1, F2, x_r)
        return np.array([*x, F1, F2, x_r, self.u])


def in_band(x: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """A displacement truth as the estimates can see it: through the conditioning's band
    (the ECUs' `in_band`, which `vehil sweep` scores their displacements against)."""
    return band_limit(x, p["T"], p["f_hp"], p["f_lp"], p["f_post"])


def ecu(p: Mapping[str, float]) -> Ecu:
    """The board's task with the observer the parameters name (variant A or B)."""
    return Ecu(p)


def no_update(p: Mapping[str, float]) -> Ecu:
    return Ecu(p, NoUpdate(p))


SPEC = register(
    EstimatorSpec(
        name="eso",
        budget={"FIXED": 5_000},
        c_id=40,
        title="Quarter-car ECU: conditioning + ESO (A/B) + predictive controller (seed 003)",
        inputs=INPUTS,
        outputs=OUTPUTS,
        reference=ecu,
        params=(
            T_PARAM,
            Param("eps", "s", q=24, default=0.1, lo=0.001, hi=2.0, doc="ESO ε: poles at -1/ε"),
            Param("variant", "1", q=0, default=VARIANT_A, lo=0, hi=1, doc="0 A literal, 1 B"),
            Param(
                "design",
                "1",
                q=0,
                default=DESIGN_PAPER,
                lo=0,
                hi=1,
                doc="gains: 0 the paper's 3/ε, 3/ε², 1/ε³; 1 the Euler loop's poles at e^(-T/ε)",
            ),
            Param(
                "road_from",
                "1",
                q=0,
                default=ROAD_FROM_MODEL,
                lo=0,
                hi=1,
                doc="x̂_r's strut force: 0 the nominal strut at x̂ (paper), 1 -m_s F̂1",
            ),
            *conditioning_params(),
            *model_params(),
            *CONTROL_PARAMS,
        ),
        rules=(gains_fit_fixed,),
        paper="003-eso-quarter-car",
        extra={"in_band": in_band},
    )
)
