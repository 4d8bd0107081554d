"""Seed 003's EKF with an unknown input (KF-UI, the paper's Sec. 5 and Appendix, after
Yang, Pan & Huang).

States [x_s, ẋ_s, x_us, ẋ_us], the unknown input x_r estimated each step by generalised
least squares; four outputs y = [x_s, ẍ_s, x_us, ẍ_us]: the conditioned displacements and
the raw (biased, noisy) accelerations. Recursion (26)-(33) as docs/estimators/kfui.md reads it:
prediction with the printed forward Euler, F = I + T J, or RK4 with F = expm(J T)
(`KfUi(p, rk4=True)`, host only: Euler at 100 Hz is unstable for the wheel-hop mode open
loop, |1 + λT| = 1.079, and the board runs Euler); the covariance update as printed (33).
Q = 10⁻² I and R = diag(r_x, r_a, r_x, r_a) as the paper's; P0 = p0 I and S0 = s0 are not in
the paper (our choice).

The `kfui` spec is the board's task with the KF-UI in place of the ESO (float32 only):
conditioning -> KF-UI -> controller, same inputs and outputs as `eso`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np
from scipy.linalg import expm

from vehil.estimators import register
from vehil.estimators._accel_conditioning import params as conditioning_params
from vehil.estimators._health import WindowMean, nis_outside, outside_3sigma
from vehil.estimators._suspension_control import PARAMS as CONTROL_PARAMS
from vehil.estimators.base import EstimatorSpec, Param
from vehil.estimators.eso import INPUTS, OUTPUTS, T_PARAM, Ecu, Measured, in_band
from vehil.models.quarter_car import model_params, nominal


class KfUi:
    def __init__(self, p: Mapping[str, float], rk4: bool = False):
        self.m = replace(nominal(p), damper_hold=p["damper_hold"] >= 0.5)
        self.T = p["T"]
        self.rk4 = rk4
        self.Q = p["q"] * np.eye(4)
        self.R = np.diag([p["r_x"], p["r_a"], p["r_x"], p["r_a"]])
        self.Rinv = np.linalg.inv(self.R)
        self.D = np.array([0.0, 0.0, 0.0, self.m.d1])
        self.x = np.zeros(4)
        self.P = p["p0"] * np.eye(4)
        self.d = 0.0  # û*, the road input
        self.S = p["s0"]
        self.x_max = p["x_max"]
        self.nis = WindowMean(self.T, p["nis_window"])  # of the innovation's χ²(3)
        self.nis_max = p["nis_max"]
        self.diverged: list[bool] = []

    def h(self, x: np.ndarray, u: float, x_r: float) -> np.ndarray:
        """Eq. (39)."""
        a_s, a_us = self.m.f1(x) + u / self.m.m_s, self.m.f2(x) + self.m.d1 * x_r - u / self.m.m_us
        return np.array([x[0], a_s, x[2], a_us])

    def H(self, x: np.ndarray) -> np.ndarray:
        """Eqs. (40)-(41): the displacement rows and the Jacobian's acceleration rows."""
        J = self.m.jacobian(x)
        return np.array([[1.0, 0, 0, 0], J[1], [0, 0, 1.0, 0], J[3]])

    def _f(self, x: np.ndarray, u: float) -> np.ndarray:
        d = self.m.deriv(x, u, 0.0)
        d[3] += self.m.d1 * self.d  # f2 + d1 x_r with the nominal (linear) tire
        return np.array(d)

    def predict(self, u: float) -> tuple[np.ndarray, np.ndarray]:
        x, T = self.x, self.T
        J = self.m.jacobian(x)
        if not self.rk4:
            return x + T * self._f(x, u), np.eye(4) + T * J  # (35)-(36)
        k1 = self._f(x, u)
        k2 = self._f(x + T / 2 * k1, u)
        k3 = self._f(x + T / 2 * k2, u)
        k4 = self._f(x + T * k3, u)
        return x + T / 6 * (k1 + 2 * k2 + 2 * k3 + k4), expm(J * T)

    def step(self, y: np.ndarray, u: float) -> None:
        xb, F = self.predict(u)
        Pb = F @ self.P @ F.T + self.Q  # (28)
        H, D = self.H(xb), self.D
        Sigma = self.R + H @ Pb @ H.T
        try:
            np.linalg.cholesky(Sigma)
        except np.linalg.LinAlgError:  # as the board: SINGULAR, the prediction kept
            self.x, self.P = xb, Pb
        else:
            Sigma_inv = np.linalg.inv(Sigma)
            K = Pb @ H.T @ Sigma_inv  # (29)
            W = self.Rinv @ (np.eye(4) - H @ K)
            self.S = 1.0 / float(D @ W @ D)  # (30)
            r = y - self.h(xb, u, self.d) + D * self.d
            self.nis.update(nis_outside(r, Sigma_inv, D))  # the road takes D's part
            d = self.S * float(D @ W @ r)  # (31)
            self.x = xb + K @ (y - self.h(xb, u, self.d) - D * (d - self.d))  # (32)
            self.P = (
                (np.eye(4) + np.outer(K @ D * self.S, D) @ self.Rinv @ H) @ (np.eye(4) - K @ H) @ Pb
            )  # (33)
            self.d = d
        self.diverged.append(not self.healthy())

    def healthy(self) -> bool:
        """The health check (docs/estimators/kfui.md, "Health")."""
        x_max, x, P = self.x_max, self.x, self.P
        return (
            self.nis.mean <= self.nis_max
            and bool(np.all(np.diag(P) >= 0.0))
            and self.S >= 0.0
            and not any(
                outside_3sigma(v, -x_max, x_max, var)
                for v, var in ((x[0], P[0, 0]), (x[2], P[2, 2]), (self.d, self.S))
            )
        )

    def update(self, m: Measured, u: float) -> None:
        self.step(np.array([m.y_s, m.a_s, m.y_us, m.a_us]), u)

    def estimates(self) -> tuple[np.ndarray, float, float, float]:
        m = self.m
        return self.x.copy(), m.f1(self.x), m.f2(self.x) + m.d1 * self.d, self.d


def ecu(p: Mapping[str, float], rk4: bool = False) -> Ecu:
    """The board's task with the KF-UI as its observer (RK4: host only)."""
    return Ecu(p, KfUi(p, rk4))


SPEC = register(
    EstimatorSpec(
        name="kfui",
        budget={"F32": 120_000},
        c_id=41,
        title="Quarter-car ECU: conditioning + KF-UI + predictive controller (seed 003)",
        inputs=INPUTS,
        outputs=OUTPUTS,
        reference=ecu,
        params=(
            T_PARAM,
            Param("q", "1", default=1e-2, lo=1e-9, hi=1e3, doc="process noise Q = q I"),
            Param("r_x", "m^2", default=0.1, lo=1e-9, hi=1e3, doc="R: displacement channels"),
            Param("r_a", "m^2/s^4", default=1.0, lo=1e-9, hi=1e3, doc="R: acceleration channels"),
            Param("p0", "1", default=1e-2, lo=0, hi=1e3, doc="P0 = p0 I"),
            Param("s0", "m^2", default=1.0, lo=0, hi=1e3, doc="S0"),
            Param("nis_max", "1", default=1.0, lo=0.1, hi=1e6, doc="NIS mean that flags"),
            Param("nis_window", "s", default=1.0, lo=0.05, hi=100.0, doc="NIS averaging time"),
            Param(
                "x_max",
                "m",
                default=0.3,
                lo=0.01,
                hi=10.0,
                doc="plausible |x̂_s|, |x̂_us|, |x̂_r| (about the conditioned frame's zero)",
            ),
            Param(
                "damper_hold",
                "1",
                default=0,
                lo=0,
                hi=1,
                doc="1: the model's literal damper holds its peak force past -c1/2c2",
            ),
            *conditioning_params(),
            *model_params(),
            *CONTROL_PARAMS,
        ),
        modes=("F32",),
        paper="003-eso-quarter-car",
        extra={"in_band": in_band},
    )
)
