"""UIIEKF: vehicle speed during braking with the brake torque as an unknown input (seed 000).

The model is the braking plant's single-track model (vehil.plants.braking, note
§1) with its nominal tires, Euler-discretised: x(k+1) = x + T f(x, δ=0, T_b=0)
+ B d, B = T [0, 0, 0, -K_b, -(1 - K_b)]ᵀ / I_ω (only its direction matters,
note §1.2). The measurement update removes any innovation along C B, so the
unknown torque never pulls the speed (note §2.1, Gillijns-De Moor):
    F = C P Cᵀ + R,  K = P Cᵀ F⁻¹,  L = K + (I - K C) B (Bᵀ Cᵀ F⁻¹ C B)⁻¹ Bᵀ Cᵀ F⁻¹
    x += L (z - C x),  P = (I - L C) P (I - L C)ᵀ + L R Lᵀ
repeated N times as printed (eq. 36: the same z applied N times), or once
(`form = 1`: the standard IEKF, which re-linearises h; h is linear here, so one
pass is the whole iteration). Time update (eq. 37) with the Jacobian J_φ = I + T ∂f/∂x by
forward differences. Tuning (Table 3): P(0) = 10 I, R = 0.01 I, Q small.

`n_states = 3` is the straight-line reduction of note §1.6 (v_y = r = 0): states
[v_x, ω_f, ω_r], the same equations with δ = 0.

The sample time is not in the paper; 10 ms is the usual period of ABS wheel-speed
signals and fits the 3-state filter's cost on the ATmega2560 (13 ms measured:
it needs T >= 15 ms there to keep real time). `Uikf` is the linear UIKF of eqs.
27-28 on the model linearised once, at the first estimate.

The reference keeps its diagnostics per step: ‖(I - L C) B‖ (condition C1, ≈ 0)
and the eigenvalues of (I - L C) J_φ (condition C2, inside the unit circle).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from vehil.estimators import register
from vehil.estimators.base import EstimatorSpec, Param, Signal
from vehil.estimators.manf import WHEEL_SPEEDS
from vehil.plants import braking

STATE_NAMES = {5: ("v_x", "v_y", "r", "omega_f", "omega_r"), 3: ("v_x", "omega_f", "omega_r")}


class Uiiekf:
    """step([ω_f, ω_r]) -> [v̂_x, d̂] with d̂ the unknown input's estimate (brake torque)."""

    def __init__(self, p: Mapping[str, float]):
        self.p = p
        self.n = int(p["n_states"])
        self.T = p["T"]
        surface = braking.SURFACES[int(p["surface"])]
        self.tires = surface[1:]
        n = self.n
        self.C = np.zeros((2, n))
        self.C[0, n - 2] = self.C[1, n - 1] = 1.0
        self.B = np.zeros((n, 1))
        self.B[n - 2, 0] = -braking.K_B * self.T / braking.I_W
        self.B[n - 1, 0] = -(1 - braking.K_B) * self.T / braking.I_W
        self.Q = np.diag([p["q_v"]] + [p["q_lat"]] * (n - 3) + [p["q_w"]] * 2)
        self.R = np.eye(2) * p["r_meas"]
        self.x: np.ndarray | None = None
        self.P = np.eye(n) * p["p0"]
        self.d_x = 0.0
        self.c1_norm: list[float] = []
        self.eigenvalues: list[np.ndarray] = []

    def _full(self, x: np.ndarray) -> np.ndarray:
        return x if self.n == 5 else np.array([x[0], 0.0, 0.0, x[1], x[2]])

    def xdot(self, x: np.ndarray) -> np.ndarray:
        """ẋ with no brake torque (it is the unknown input), in the filter's states."""
        dx = braking.derivatives(self._full(x), 0.0, 0.0, self.d_x, self.tires, printed=False)
        return dx if self.n == 5 else dx[[0, 3, 4]]

    def jacobian(self, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """J_φ = I + T ∂ẋ/∂x by forward differences (as the board computes it)."""
        n = self.n
        J = np.eye(n)
        for j in range(n):
            h = 1e-3 * max(1.0, abs(x[j]))
            e = np.zeros(n)
            e[j] = h
            J[:, j] += self.T * (self.xdot(x + e) - dx) / h
        return J

    def predict(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Eq. 37: φ(x) and its Jacobian J_φ."""
        dx = self.xdot(x)
        J = self.jacobian(x, dx)
        self.d_x = dx[0]  # the model's deceleration, for the loads
        return x + self.T * dx, J

    def step(self, u: np.ndarray) -> np.ndarray:
        z = np.asarray(u, dtype=np.float64)[:2]
        if self.x is None:
            w_f, w_r = z
            v0 = braking.R_W * w_f  # v_x(0) = R ω_f(0): no slip before braking
            self.x = np.array([v0, 0.0, 0.0, w_f, w_r]) if self.n == 5 else np.array([v0, w_f, w_r])
        x, P, C, B, R = self.x, self.P, self.C, self.B, self.R
        identity = np.eye(self.n)
        passes = int(self.p["iterations"]) if self.p["form"] < 0.5 else 1
        innovation = z - C @ x
        for _ in range(passes):
            F_inv = np.linalg.inv(C @ P @ C.T + R)
            K = P @ C.T @ F_inv
            CB = C @ B
            L = K + (identity - K @ C) @ B @ np.linalg.inv(CB.T @ F_inv @ CB) @ CB.T @ F_inv
            x = x + L @ (z - C @ x)
            IL = identity - L @ C
            P = IL @ P @ IL.T + L @ R @ L.T
        d_hat = float((np.linalg.pinv(C @ B) @ innovation)[0])
        x_next, J = self.predict(x)
        self.c1_norm.append(float(np.linalg.norm(IL @ B)))
        self.eigenvalues.append(np.linalg.eigvals(IL @ J))
        v_out = float(x[0])
        self.x = x_next
        self.P = J @ P @ J.T + self.Q
        return np.array([v_out, d_hat])


class Uikf(Uiiekf):
    """The linear UIKF (eqs. 27-28): x(k+1) = φ(x0) + A (x - x0), A = J_φ(x0) frozen."""

    linear_at: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def predict(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.linear_at is None:
            phi0, A = super().predict(x)
            self.linear_at = (x.copy(), phi0, A)
        x0, phi0, A = self.linear_at
        return phi0 + A @ (x - x0), A


SPEC = register(
    EstimatorSpec(
        name="uiiekf",
        budget={"F32": 120_000},
        c_id=21,
        title="UIIEKF: iterated EKF with the brake torque as an unknown input (seed 000)",
        inputs=WHEEL_SPEEDS,
        outputs=(
            Signal("v", "m/s", q=16, doc="vehicle speed v̂_x"),
            Signal("d", "rad/s", q=16, doc="unknown-input innovation along C B (torque sign)"),
        ),
        reference=Uiiekf,
        params=(
            Param("T", "s", default=0.01, lo=1e-4, hi=0.1, doc="sample time (see above)"),
            Param("n_states", "1", default=5, lo=3, hi=5, doc="5, or 3 (straight line)"),
            Param("iterations", "1", default=1, lo=1, hi=10, doc="N of eq. 36 (not given)"),
            Param("form", "1", default=0, lo=0, hi=1, doc="0 printed iteration, 1 standard"),
            Param("surface", "1", default=0, lo=0, hi=6, doc="the model's nominal tires"),
            Param("p0", "1", default=10.0, lo=1e-6, hi=1e3, doc="P(0) = p0 I (Table 3)"),
            Param("q_v", "(m/s)^2", default=1e-4, lo=0.0, hi=10.0),
            Param("q_lat", "1", default=1e-6, lo=0.0, hi=10.0),
            Param("q_w", "(rad/s)^2", default=1e-2, lo=0.0, hi=100.0),
            Param("r_meas", "(rad/s)^2", default=0.01, lo=1e-6, hi=100.0, doc="R (Table 3)"),
        ),
        modes=("F32",),
        paper="000-manf-uiiekf-braking",
    )
)
