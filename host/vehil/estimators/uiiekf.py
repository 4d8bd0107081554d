"""UIIEKF: vehicle speed during braking with the brake torque as an unknown input (seed 000).

The filter's model is its own (docs/estimators/uiiekf.md): the single-track braking model of
the paper's eqs. 1-16 with δ = 0 and no brake torque, the consistent reading of the loads
and forces, Burckhardt tires (c1, c2, c3: dry asphalt's by default), and the car's
parameters (Table 2, the Pride, by default: m, R, I_ω, K_b, ψ, h, L_f, L_r are parameters,
so another car is a few lines of a scenario). Euler-discretised: x(k+1) = x + T f(x) + B d,
B = T [0, 0, 0, -K_b, -(1 - K_b)]ᵀ / I_ω (only its direction matters: scaling B leaves the
gain L unchanged). The measurement update removes any innovation along C B, so the unknown
torque never pulls the speed (the paper's linear UIKF after its ref. [28], the form of
Gillijns & De Moor):
    F = C P Cᵀ + R,  K = P Cᵀ F⁻¹,  L = K + (I - K C) B (Bᵀ Cᵀ F⁻¹ C B)⁻¹ Bᵀ Cᵀ F⁻¹
    x += L (z - C x),  P = (I - L C) P (I - L C)ᵀ + L R Lᵀ
repeated N times as printed (eq. 36: the same z applied N times), or once
(`form = 1`: the standard IEKF, which re-linearises h; h is linear here, so one
pass is the whole iteration). Time update (eq. 37) with the analytic Jacobian
J_φ = I + T ∂f/∂x. Tuning (Table 3): P(0) = 10 I, R = 0.01 I. Q is "small" in the paper;
here its entries are densities per second (Q = T diag(q_v, q_lat.., q_w, q_w)), so the
filter is the same at any T, and q_w's default covers the wheel torque the model does not
explain (tire relaxation, another car's inertia and brake split): docs/estimators/uiiekf.md.

`n_states = 3` is the straight-line reduction (v_y = r = 0): states
[v_x, ω_f, ω_r], the same equations with δ = 0. With δ = 0 the 5-state model's lateral
block is decoupled from the wheels exactly (∂F_x/∂v_lat = ∂F_y/∂ω = 0 at v_lat = 0), so
v_y and r stay zero and the 5-state filter gives the 3-state one's speed.

Health (status DIVERGED): the innovation left after the unknown input takes its
direction is one χ²(1) value per step; its mean over `nis_window` (an exponential
average) above `nis_max` says the model no longer explains the wheels. So do a speed
more than 3σ outside [0, v_max] (a wheel's: [0, v_max / R]; below 0 it turns backwards),
and a speed variance above v_max² or a negative variance, after the update or after the
prediction. While both wheels turn slower than
`v_min` the slip model means nothing: the average holds, d̂ is 0 (the torque holding a
standing car is a static reaction; estimated, it would be the wheels' noise times
|(C B)⁺|), and ILL_CONDITIONED says that v̂ is not determined by the wheels.

The sample time is not in the paper; 10 ms is the usual period of ABS wheel-speed
signals. `Uikf` is the linear UIKF of eqs. 27-28 on the model linearised once, at
the first estimate.

The reference keeps its diagnostics per step: ‖(I - L C) B‖ (condition C1, ≈ 0),
the eigenvalues of (I - L C) J_φ (condition C2, inside the unit circle) and the
health check's verdict.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from vehil.braking_car import CAR_PARAMS, SURFACES, Car
from vehil.estimators import register
from vehil.estimators._health import WindowMean, nis_outside, outside_3sigma
from vehil.estimators.base import EstimatorSpec, Param, Signal
from vehil.estimators.manf import WHEEL_SPEEDS

STATE_NAMES = {5: ("v_x", "v_y", "r", "omega_f", "omega_r"), 3: ("v_x", "omega_f", "omega_r")}
# The car's values the filter takes: all of Table 2's (m ... l_r, then the yaw inertia and
# the drag terms and gravity, appended so the wire order of the first keeps).
CAR = tuple(
    p for p in CAR_PARAMS if p.name in ("m", "r_w", "i_w", "k_b", "psi", "h_cg", "l_f", "l_r")
)
CAR_MORE = tuple(p for p in CAR_PARAMS if p.name in ("i_z", "rho", "c_d", "a_f", "h_a", "g"))
DRY = SURFACES[0][1:]
FULL = {5: [0, 1, 2, 3, 4], 3: [0, 3, 4]}  # the filter's states among the model's five


class Model:
    """ẋ = f(x) of eqs. 2-16 with δ = 0 and no brake torque, and ∂f/∂x, for the five
    states; d_x (the model's last v̇_x) sets the load transfer and is held in ∂f/∂x."""

    def __init__(self, car: Car, tires: tuple[float, float, float]):
        self.car = car
        self.c1, self.c2, self.c3 = tires

    def _wheel(
        self, w: float, v: float, v_lat: float, f_z: float, df_z: float
    ) -> tuple[float, float, np.ndarray, np.ndarray]:
        """F_x, F_y and their partials by (v, v_lat, ω): braking-positive slips
        s_x = 1 - R ω v / q, s_y = -R ω v_lat / q (q = v² + v_lat², cos α = v / √q)."""
        car, psi = self.car, self.car.psi
        inv_q = 1.0 / (v * v + v_lat * v_lat)
        a = car.r_w * w * inv_q
        s_x, s_y = 1.0 - a * v, -a * v_lat
        c = a * (v * v - v_lat * v_lat) * inv_q
        e = 2.0 * a * v * v_lat * inv_q
        ds_x = np.array([c, e, -car.r_w * v * inv_q])
        ds_y = np.array([e, -c, -car.r_w * v_lat * inv_q])
        s = math.hypot(s_x, s_y)
        if s < 1e-6:  # μ/λ at its limit; μ' - μ/λ -> 0
            g, h, n_x, n_y = psi * (self.c1 * self.c2 - self.c3), 0.0, 0.0, 0.0
        else:
            x = math.exp(-self.c2 * s)
            mu = psi * (self.c1 * (1.0 - x) - self.c3 * s)
            g = mu / s
            h = psi * (self.c1 * self.c2 * x - self.c3) - g  # μ'(s) - μ(s)/s
            n_x, n_y = s_x / s, s_y / s
        dn = n_x * ds_x + n_y * ds_y  # ∂s
        dz = np.array([df_z, 0.0, 0.0])
        dF_x = f_z * (g * ds_x + h * n_x * dn) + g * s_x * dz
        dF_y = f_z * (g * ds_y + h * n_y * dn) + g * s_y * dz
        return g * f_z * s_x, g * f_z * s_y, dF_x, dF_y

    def f_and_jacobian(self, x: np.ndarray, d_x: float) -> tuple[np.ndarray, np.ndarray]:
        car = self.car
        v_x, v_y, r, w_f, w_r = x
        v, dv = (v_x, 1.0) if v_x > 0.1 else (0.1, 0.0)
        L = car.wheelbase
        k_drag = 0.5 * car.rho * car.c_d * car.a_f * car.h_a / (2 * L)
        transfer = car.m * d_x * car.h_cg / (2 * L)
        loads = (
            (car.weight * car.l_r / (2 * L) - transfer - k_drag * v * v, -2 * k_drag * v),
            (car.weight * car.l_f / (2 * L) + transfer + k_drag * v * v, 2 * k_drag * v),
        )
        A = np.zeros((5, 5))
        F = []
        for i, (w, lever) in enumerate(((w_f, car.l_f), (w_r, -car.l_r))):
            f_z, df_z = loads[i] if loads[i][0] > 0 else (0.0, 0.0)
            f_x, f_y, dF_x, dF_y = self._wheel(w, v, v_y + lever * r, f_z, df_z)
            F.append((f_x, f_y))
            # by state: v_x (through v), v_y and r (through v_lat), this wheel's ω
            cols = [0, 1, 2, 3 + i]
            dx_i = np.array([dv * dF_x[0], dF_x[1], lever * dF_x[1], dF_x[2]])
            dy_i = np.array([dv * dF_y[0], dF_y[1], lever * dF_y[1], dF_y[2]])
            A[0, cols] -= 2.0 / car.m * dx_i
            A[1, cols] += 2.0 / car.m * dy_i
            A[2, cols] += 2.0 * lever / car.i_z * dy_i
            A[3 + i, cols] += car.r_w / car.i_w * dx_i
        (f_xf, f_yf), (f_xr, f_yr) = F
        f = np.array(
            [
                -2.0 * (f_xf + f_xr) / car.m + r * v_y,
                2.0 * (f_yf + f_yr) / car.m - r * v,
                2.0 * (car.l_f * f_yf - car.l_r * f_yr) / car.i_z,
                car.r_w * f_xf / car.i_w,
                car.r_w * f_xr / car.i_w,
            ]
        )
        A[0, 1] += r
        A[0, 2] += v_y
        A[1, 0] -= r * dv
        A[1, 2] -= v
        return f, A


class Uiiekf:
    """step([ω_f, ω_r]) -> [v̂_x, d̂] with d̂ the unknown input's estimate (brake torque)."""

    def __init__(self, p: Mapping[str, float]):
        self.p = p
        self.n = int(p["n_states"])
        self.T = p["T"]
        self.car = Car.of({q.name: q.default for q in CAR_PARAMS} | dict(p))
        self.model = Model(self.car, (p["c1"], p["c2"], p["c3"]))
        n = self.n
        self.C = np.zeros((2, n))
        self.C[0, n - 2] = self.C[1, n - 1] = 1.0
        self.B = np.zeros((n, 1))
        self.B[n - 2, 0] = -self.car.k_b * self.T / self.car.i_w
        self.B[n - 1, 0] = -(1 - self.car.k_b) * self.T / self.car.i_w
        # Q's densities are per second (docs/estimators/uiiekf.md): the same filter at any T.
        self.Q = np.diag([p["q_v"]] + [p["q_lat"]] * (n - 3) + [p["q_w"]] * 2) * self.T
        self.R = np.eye(2) * p["r_meas"]
        self.x: np.ndarray | None = None
        self.P = np.eye(n) * p["p0"]
        self.d_x = 0.0
        self.nis = WindowMean(self.T, p["nis_window"])  # of the innovation's χ²(1)
        self.c1_norm: list[float] = []
        self.eigenvalues: list[np.ndarray] = []
        self.diverged: list[bool] = []
        self.standstill: list[bool] = []  # ILL_CONDITIONED: d̂ and v̂ not from the wheels

    def xdot(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """ẋ with no brake torque (it is the unknown input) and ∂ẋ/∂x, in the filter's states."""
        full = x if self.n == 5 else np.array([x[0], 0.0, 0.0, x[1], x[2]])
        f, A = self.model.f_and_jacobian(full, self.d_x)
        keep = FULL[self.n]
        return f[keep], A[np.ix_(keep, keep)]

    def predict(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Eq. 37: φ(x) and its Jacobian J_φ = I + T ∂f/∂x."""
        dx, A = self.xdot(x)
        self.d_x = dx[0]  # the model's deceleration, for the loads
        return x + self.T * dx, np.eye(self.n) + self.T * A

    def _covariance_ok(self, P: np.ndarray) -> bool:
        return bool(P[0, 0] <= self.p["v_max"] ** 2 and np.all(np.diag(P) >= 0.0))

    def _estimate_ok(self, x: np.ndarray, P: np.ndarray) -> bool:
        w_max = self.p["v_max"] / self.car.r_w
        return (
            self.nis.mean <= self.p["nis_max"]
            and self._covariance_ok(P)
            and not outside_3sigma(x[0], 0.0, self.p["v_max"], P[0, 0])
            and not any(outside_3sigma(x[i], 0.0, w_max, P[i, i]) for i in (-2, -1))
        )

    def step(self, u: np.ndarray) -> np.ndarray:
        z = np.asarray(u, dtype=np.float64)[:2]
        if self.x is None:
            w_f, w_r = z
            v0 = self.car.r_w * w_f  # v_x(0) = R ω_f(0): no slip before braking
            self.x = np.array([v0, 0.0, 0.0, w_f, w_r]) if self.n == 5 else np.array([v0, w_f, w_r])
        x, P, C, B, R = self.x, self.P, self.C, self.B, self.R
        identity = np.eye(self.n)
        passes = int(self.p["iterations"]) if self.p["form"] < 0.5 else 1
        innovation = z - C @ x
        CB = C @ B
        for i in range(passes):
            F_inv = np.linalg.inv(C @ P @ C.T + R)
            if i == 0 and self.car.r_w * max(z) >= self.p["v_min"]:
                self.nis.update(nis_outside(z - C @ x, F_inv, CB[:, 0]))
            K = P @ C.T @ F_inv
            L = K + (identity - K @ C) @ B @ np.linalg.inv(CB.T @ F_inv @ CB) @ CB.T @ F_inv
            x = x + L @ (z - C @ x)
            IL = identity - L @ C
            P = IL @ P @ IL.T + L @ R @ L.T
        healthy = self._estimate_ok(x, P)
        standing = self.car.r_w * max(z) < self.p["v_min"]
        self.standstill.append(standing)
        # standing, the torque holding the car is a static reaction: none is estimated
        d_hat = 0.0 if standing else float((np.linalg.pinv(CB) @ innovation)[0])
        x_next, J = self.predict(x)
        self.c1_norm.append(float(np.linalg.norm(IL @ B)))
        self.eigenvalues.append(np.linalg.eigvals(IL @ J))
        v_out = float(x[0])
        self.x = x_next
        self.P = J @ P @ J.T + self.Q
        self.diverged.append(not (healthy and self._covariance_ok(self.P)))
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
            Param("T", "s", q=0, default=0.01, lo=1e-4, hi=0.1, doc="sample time (see above)"),
            Param("n_states", "1", q=0, default=5, lo=3, hi=5, doc="5, or 3 (straight line)"),
            Param("iterations", "1", q=0, default=1, lo=1, hi=10, doc="N of eq. 36"),
            Param("form", "1", q=0, default=0, lo=0, hi=1, doc="0 printed iteration, 1 once"),
            Param(
                "c1", "1", q=0, default=DRY[0], lo=0.0, hi=2.0, doc="model's tires: Burckhardt c1"
            ),
            Param("c2", "1", q=0, default=DRY[1], lo=1.0, hi=500.0, doc="c2 (dry asphalt's)"),
            Param("c3", "1", q=0, default=DRY[2], lo=0.0, hi=1.0, doc="c3"),
            Param("p0", "1", q=0, default=10.0, lo=1e-6, hi=1e3, doc="P(0) = p0 I (Table 3)"),
            Param("q_v", "(m/s)^2/s", q=0, default=0.01, lo=0.0, hi=1e3, doc="speed model's error"),
            Param("q_lat", "1/s", q=0, default=1e-4, lo=0.0, hi=1e3, doc="v_y and r's"),
            Param("q_w", "(rad/s)^2/s", q=0, default=300.0, lo=0.0, hi=1e5, doc="paper's: 1"),
            Param("r_meas", "(rad/s)^2", q=0, default=0.01, lo=1e-6, hi=100.0, doc="R (Table 3)"),
            *CAR,
            Param("v_max", "m/s", q=0, default=100.0, lo=1.0, hi=200.0, doc="highest speed"),
            Param("nis_max", "1", q=0, default=5.0, lo=1.0, hi=1e6, doc="NIS mean that flags"),
            Param(
                "v_min",
                "m/s",
                q=0,
                default=1.0,
                lo=0.0,
                hi=10.0,
                doc="both wheels slower: standstill (NIS held, ILL_CONDITIONED)",
            ),
            Param("nis_window", "s", q=0, default=1.0, lo=0.1, hi=100.0, doc="NIS averaging time"),
            *CAR_MORE,
        ),
        modes=("F32",),
        paper="000-manf-uiiekf-braking",
    )
)
