"""Seed 001's distributed-drive EV: the car as data and the filters' 7-state model.

Every vehicle and tire constant is a parameter (CAR_PARAMS, a `Car`), in the filters'
CONFIG and, separately, in the truth plant (plants/ev4wd.py), so a scenario gives each
its car: the same one as the paper assumes ("vehicle parameters known"), or another to
measure the mismatch. The paper gives no vehicle or tire numbers (its truth was
CarSim's car): the defaults are ours, a compact passenger EV (docs/estimators/ev.md).
Wheels 1 FL, 2 FR, 3 RL, 4 RR (eq. (22) steers 1 and 2; left before right is our
reading); ISO axes, y left, yaw positive counter-clockwise.

The model (the paper's Section 3, eqs. (21)-(30)), vectorised over any leading batch
axes so the UPF runs N × 43 sigma points in one call:
- x = [v_x, v_y, γ, F̃_1y..F̃_4y]; u = (δ, F_1x..F_4x) and the loads F_z,i;
- ẋ from eqs. (1)-(7) and the relaxation (20) with σ_α = k_α0 / k_y0, forward Euler
  at the filter's sample time (the paper does not say how it discretises (26));
- y = h(x, u) = [a_x, a_y, γ, ω_1..ω_4] from (5) and (29) with κ̂_i = F_ix / k_κ0 (28).
The inputs the filters get are the sensors (a_x, a_y, γ, ω_i, δ, motor torques T_i);
`Preprocess` turns them into u: F_ix = (T_i - I_w ω̇_i)/R (21) with ω̇ from a filtered
difference of the measured wheel speed, and the loads from the measured a_x, a_y by a
quasi-static transfer (`loads`: the paper does not say how it gets F_z).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from vehil.spec import Param, ParamRecord, Signal

# The car: every vehicle and tire constant of the model, a parameter of the filters (their
# CONFIG) and, separately, of the truth plant. Defaults: ours, the paper gives none.
CAR_PARAMS = (
    Param("m", "kg", default=1400.0, lo=200.0, hi=5000.0, doc="vehicle mass"),
    Param("i_z", "kg*m^2", default=1900.0, lo=50.0, hi=20_000.0, doc="yaw inertia"),
    Param("l_f", "m", default=1.10, lo=0.3, hi=3.0, doc="CG to front axle"),
    Param("l_r", "m", default=1.45, lo=0.3, hi=3.0, doc="CG to rear axle"),
    Param("track", "m", default=1.50, lo=0.8, hi=2.5, doc="track width, front = rear"),
    Param("h_cg", "m", default=0.50, lo=0.1, hi=2.0, doc="CG height (load transfer)"),
    Param("r_wheel", "m", default=0.30, lo=0.1, hi=1.0, doc="wheel rolling radius"),
    Param("i_w", "kg*m^2", default=1.2, lo=0.05, hi=50.0, doc="wheel + motor inertia (21)"),
    Param("rho", "kg/m^3", default=1.206, lo=0.5, hi=1.5, doc="air density (3)"),
    Param("c_d", "1", default=0.30, lo=0.0, hi=2.0, doc="drag coefficient (3)"),
    Param("a_f", "m^2", default=2.2, lo=0.5, hi=10.0, doc="frontal area (3)"),
    Param("f_roll", "1", default=0.015, lo=0.0, hi=0.1, doc="rolling-resistance coefficient"),
    Param("g", "m/s^2", default=9.81, lo=9.0, hi=10.5, doc="gravity"),
    Param("b_x", "1", default=10.0, lo=1.0, hi=50.0, doc="MF B_x (14): k_κ0 = B_x C_x μF_z"),
    Param("c_x", "1", default=1.9, lo=0.5, hi=3.0, doc="MF C_x (14)"),
    Param("b_y", "1/rad", default=10.0, lo=1.0, hi=50.0, doc="MF B_y (15)"),
    Param("c_y", "1", default=1.3, lo=0.5, hi=2.0, doc="MF C_y (15)"),
    Param("e_y", "1", default=0.0, lo=-3.0, hi=1.0, doc="MF E_y (15)"),
    Param("b_xa", "1/rad", default=10.0, lo=0.0, hi=50.0, doc="G_xα's B_xα (16), S_H = 0"),
    Param("c_xa", "1", default=1.0, lo=0.5, hi=1.0, doc="G_xα's C_xα (16)"),
    Param("b_yk", "1", default=10.0, lo=0.0, hi=50.0, doc="G_yκ's B_yκ (17), S_H = 0"),
    Param("c_yk", "1", default=1.0, lo=0.5, hi=1.0, doc="G_yκ's C_yκ (17)"),
    Param("sigma_y", "m", default=0.4, lo=0.05, hi=3.0, doc="relaxation length k_α0/k_y0 (20)"),
    Param("tau_wdot", "s", default=0.02, lo=1e-3, hi=1.0, doc="ω̇ low-pass time constant (21)"),
)


@dataclass(frozen=True)
class Car(ParamRecord):
    """The values of CAR_PARAMS, by name, and what the model derives from them."""

    m: float
    i_z: float
    l_f: float
    l_r: float
    track: float
    h_cg: float
    r_wheel: float
    i_w: float
    rho: float
    c_d: float
    a_f: float
    f_roll: float
    g: float
    b_x: float
    c_x: float
    b_y: float
    c_y: float
    e_y: float
    b_xa: float
    c_xa: float
    b_yk: float
    c_yk: float
    sigma_y: float
    tau_wdot: float

    @property
    def wheelbase(self) -> float:
        return self.l_f + self.l_r

    @property
    def drag(self) -> float:
        """½ ρ C_d A of (3)."""
        return 0.5 * self.rho * self.c_d * self.a_f

    @property
    def roll(self) -> float:
        """m g f of (3) on a level road."""
        return self.m * self.g * self.f_roll

    @cached_property
    def lx(self) -> np.ndarray:
        """Wheel centres' l_i: +l_f front, -l_r rear."""
        return np.array([self.l_f, self.l_f, -self.l_r, -self.l_r])

    @cached_property
    def byw(self) -> np.ndarray:
        """Wheel centres' b_i, ±track/2, left positive."""
        return np.array([self.track / 2, -self.track / 2, self.track / 2, -self.track / 2])


SHIPPED = Car.of({p.name: p.default for p in CAR_PARAMS})
STEERED = np.array([1.0, 1.0, 0.0, 0.0])  # (22): front wheels only

N_X, N_Y = 7, 7

INPUTS = (
    Signal("ax", "m/s^2", doc="longitudinal acceleration sensor"),
    Signal("ay", "m/s^2", doc="lateral acceleration sensor"),
    Signal("gz", "rad/s", doc="yaw-rate sensor"),
    *(Signal(f"w{i}", "rad/s", doc=f"wheel {i} speed (motor resolver)") for i in range(1, 5)),
    Signal("delta", "rad", doc="front road-wheel steer angle"),
    *(Signal(f"tq{i}", "N*m", doc=f"motor {i} torque") for i in range(1, 5)),
)
OUTPUTS = (
    Signal("vx", "m/s", doc="longitudinal speed"),
    Signal("vy", "m/s", doc="lateral speed"),
    Signal("r", "rad/s", doc="yaw rate"),
    *(Signal(f"fy{i}", "N", doc=f"wheel {i} lateral force (tire frame)") for i in range(1, 5)),
    Signal("beta", "deg", doc="sideslip angle atan(v_y / v_x)"),
)

# The plant's sensor noise (plants/ev4wd.py; the paper gives none) sets the nominal fixed R.
SD_ACC, SD_GYRO, SD_W = 0.1, math.radians(0.5), 0.2

TUNING = (
    Param("T", "s", default=0.01, lo=1e-3, hi=0.05, doc="filter sample time"),
    Param("mu", "1", default=0.85, lo=0.05, hi=1.2, doc="road friction (known, D = μF_z)"),
    Param("vx0", "m/s", default=22.2, lo=0.5, hi=60.0, doc="initial v_x"),
    Param("p0_v", "(m/s)^2", default=1.0, lo=1e-6, hi=100.0, doc="P0 of v_x"),
    Param("p0_lat", "(m/s)^2", default=0.01, lo=1e-8, hi=10.0, doc="P0 of v_y; γ gets 1 % of it"),
    Param("q_v", "(m/s)^2", default=1e-4, lo=1e-10, hi=1.0, doc="Q of v_x per step"),
    Param("q_vy", "(m/s)^2", default=1e-4, lo=1e-10, hi=1.0, doc="Q of v_y per step"),
    Param("q_r", "(rad/s)^2", default=4e-6, lo=1e-12, hi=1.0, doc="Q of γ per step"),
    Param("r_ax", "(m/s^2)^2", default=SD_ACC**2, lo=1e-8, hi=100.0, doc="fixed R: a_x"),
    Param("r_ay", "(m/s^2)^2", default=SD_ACC**2, lo=1e-8, hi=100.0, doc="fixed R: a_y"),
    Param("r_gz", "(rad/s)^2", default=SD_GYRO**2, lo=1e-10, hi=1.0, doc="fixed R: γ"),
    Param("r_w", "(rad/s)^2", default=SD_W**2, lo=1e-8, hi=100.0, doc="fixed R: each ω_i"),
    Param("adaptive", "1", default=1.0, lo=0.0, hi=1.0, doc="1: R from (66)-(69), 0: fixed"),
    # (66)-(69): c_j scale the fixed R (so tuning R keeps the rules' shape), d_j are
    # 1 / characteristic magnitude (the paper gives no c_j, d_j).
    Param("c_ax", "1", default=3.0, lo=0.0, hi=1e3, doc="c_ax1 = c_ax2 = c_ax3, × r_ax / 3"),
    Param("d_ax1", "s^2/m", default=2.0, lo=0.0, hi=1e3, doc="1/(0.5 m/s²)"),
    Param("d_ax2", "1/N", default=5e-4, lo=0.0, hi=1.0, doc="1/(2 kN) of Σ|F_x|"),
    Param("d_ax3", "1", default=10.0, lo=0.0, hi=1e3, doc="1/0.1 of Σ|κ̂|"),
    Param("c_ay", "1", default=3.0, lo=0.0, hi=1e3, doc="c_ay1 = c_ay2, × r_ay / 2"),
    Param("d_ay1", "s^2/m", default=1.0, lo=0.0, hi=1e3, doc="1/(1 m/s²)"),
    Param("d_ay2", "1/rad", default=57.3, lo=0.0, hi=1e4, doc="1/(1°) of |δ|"),
    Param("c_gz", "1", default=3.0, lo=0.0, hi=1e3, doc="c_γ1 = c_γ2, × r_gz / 2"),
    Param("d_gz1", "s/rad", default=11.5, lo=0.0, hi=1e4, doc="1/(5 °/s)"),
    Param("d_gz2", "1/rad", default=57.3, lo=0.0, hi=1e4, doc="1/(1°) of |δ|"),
    Param("c_w", "1", default=1.0, lo=0.0, hi=1e3, doc="c_ωi1..3, × r_w / 3"),
    Param("d_w1", "1", default=20.0, lo=0.0, hi=1e3, doc="1/0.05 of |κ̂_i|"),
    Param("d_w2", "s^2/m", default=0.5, lo=0.0, hi=1e2, doc="1/(2 m/s²) of |a_x|"),
    Param("d_w3", "s^2/m", default=0.5, lo=0.0, hi=1e2, doc="1/(2 m/s²) of |a_y|"),
    Param("r_clip", "1", default=100.0, lo=1.0, hi=1e6, doc="r within fixed R ×/÷ r_clip"),
)
# Every filter's first: the tuning, then the car (the C's EV_P_* order).
PARAMS = (*TUNING, *CAR_PARAMS)
# The 7-state filters' own, after PARAMS: the reduced EKF has no force states.
FORCE_PARAMS = (
    Param("p0_f", "N^2", default=4e4, lo=1.0, hi=1e8, doc="P0 of each lateral force"),
    Param("q_f", "N^2", default=2500.0, lo=1e-3, hi=1e7, doc="Q of each F̃_y per step"),
)


def loads(ax: float | np.ndarray, ay: float | np.ndarray, car: Car) -> np.ndarray:
    """F_z,i (..., 4) from the CG accelerations: static + quasi-static transfer.

    Not in the paper, which does not say how it gets the loads."""
    ax, ay = np.asarray(ax), np.asarray(ay)
    m, wb, h = car.m, car.wheelbase, car.h_cg
    front = m * car.g * car.l_r / (2 * wb) - m * ax * h / (2 * wb)
    rear = m * car.g * car.l_f / (2 * wb) + m * ax * h / (2 * wb)
    lat_f = m * ay * h * car.l_r / (car.track * wb)
    lat_r = m * ay * h * car.l_f / (car.track * wb)
    fz = np.stack([front - lat_f, front + lat_f, rear - lat_r, rear + lat_r], axis=-1)
    return np.maximum(fz, 0.0)


def roll_tanh(vx: float | np.ndarray) -> np.ndarray:
    """tanh(v_x / 0.5) of the rolling resistance, ±1 past |v_x| = 5 m/s (within 4e-9, and
    exactly 1 in float32): the board skips its tanhf there, and so does the reference."""
    vx = np.asarray(vx)
    return np.where(np.abs(vx) > 5.0, np.sign(vx), np.tanh(np.clip(vx, -5.0, 5.0) / 0.5))


def mf(x: np.ndarray, b: float, c: float, e: float, d: np.ndarray) -> np.ndarray:
    """(13): D sin(C atan(B x - E (B x - atan(B x))))."""
    bx = b * x
    return d * np.sin(c * np.arctan(bx - e * (bx - np.arctan(bx))))


def weight(x: np.ndarray, b: float, c: float) -> np.ndarray:
    """(16)/(17) with S_H = 0: cos(C atan(B x))."""
    return np.cos(c * np.arctan(b * x))


@dataclass(frozen=True)
class Inputs:
    """u for one step: δ_i (4), F_ix (4), F_z,i (4) and the measurements y (7)."""

    delta: float
    fx: np.ndarray
    fz: np.ndarray
    y: np.ndarray


class Preprocess:
    """Sensors -> u: F_ix = (T_i - I_w ω̇_i)/R with ω̇ the measured
    wheel speed's difference through a first-order low-pass (the car's τ_ω̇), and F_z
    from the measured accelerations."""

    def __init__(self, T: float, car: Car):
        self.T, self.car = T, car
        self.a = T / (car.tau_wdot + T)
        self.w_prev: np.ndarray | None = None
        self.w_dot = np.zeros(4)

    def __call__(self, z: np.ndarray) -> Inputs:
        ax, ay, gz = z[0], z[1], z[2]
        w, delta, tq = z[3:7], z[7], z[8:12]
        if self.w_prev is not None:
            self.w_dot = self.w_dot + self.a * ((w - self.w_prev) / self.T - self.w_dot)
        self.w_prev = w.copy()
        fx = (tq - self.car.i_w * self.w_dot) / self.car.r_wheel
        return Inputs(float(delta), fx, loads(ax, ay, self.car), np.array([ax, ay, gz, *w]))


@dataclass(frozen=True)
class Wheels:
    """Per-wheel kinematics and tire terms at a batch of states (..., 4 each)."""

    vix: np.ndarray  # L_iᵀ V (11)
    alpha: np.ndarray  # slip angle
    fy_qs: np.ndarray  # G_yκ(κ̂) F_y0(α) (19)
    kappa: np.ndarray  # κ̂ (28)


def wheels(x: np.ndarray, u: Inputs, car: Car, mu: float, linear: bool = False) -> Wheels:
    """With `linear`, the tires' linear range: α = -v_iy / max(|v_ix|, 0.5),
    F_y = B_y C_y μF_z α and κ̂ = F_x / (B_x C_x μF_z), no combined-slip weights."""
    vx, vy, r = x[..., 0:1], x[..., 1:2], x[..., 2:3]
    d = u.delta * STEERED
    cd, sd = np.cos(d), np.sin(d)
    vX, vY = vx - car.byw * r, vy + car.lx * r  # (8)-(9) in x_R y_R
    vix = cd * vX + sd * vY  # (11)-(12)
    viy = -sd * vX + cd * vY
    zz = viy / np.maximum(np.abs(vix), 0.5)
    dmax = mu * u.fz
    k0 = car.b_x * car.c_x * np.maximum(dmax, 1.0)  # k_κ0 (27) without G_xα
    if linear:
        alpha = -zz
        return Wheels(vix, alpha, car.b_y * car.c_y * dmax * alpha, u.fx / k0)
    alpha = -np.arctan(zz)
    kappa = u.fx / (weight(alpha, car.b_xa, car.c_xa) * k0)  # (27)-(28)
    fy_qs = weight(kappa, car.b_yk, car.c_yk) * mf(alpha, car.b_y, car.c_y, car.e_y, dmax)
    return Wheels(vix, alpha, fy_qs, kappa)


def body_forces(
    x: np.ndarray, u: Inputs, car: Car, fy: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """F_x, F_y, M at the CG (4) with the resistances (3), θ = 0, from the tire-frame
    lateral forces fy: the states F̃_iy unless given (the 3-state model's quasi-static ones)."""
    d = u.delta * STEERED
    cd, sd = np.cos(d), np.sin(d)
    fy = x[..., 3:7] if fy is None else fy
    fX = cd * u.fx - sd * fy  # (1)-(2)
    fY = sd * u.fx + cd * fy
    vx = x[..., 0]
    resist = car.drag * vx * np.abs(vx) + car.roll * roll_tanh(vx)
    return fX.sum(-1) - resist, fY.sum(-1), (car.lx * fY - car.byw * fX).sum(-1)


def f(x: np.ndarray, u: Inputs, car: Car, mu: float) -> np.ndarray:
    """ẋ (26)."""
    fx, fy, mz = body_forces(x, u, car)
    vx, vy, r = x[..., 0], x[..., 1], x[..., 2]
    w = wheels(x, u, car, mu)
    dF = np.abs(w.vix) / car.sigma_y * (w.fy_qs - x[..., 3:7])  # (20)
    return np.concatenate(
        [np.stack([fx / car.m + r * vy, fy / car.m - r * vx, mz / car.i_z], axis=-1), dF],
        axis=-1,
    )


def step(x: np.ndarray, u: Inputs, car: Car, mu: float, T: float) -> np.ndarray:
    """x_{k+1} = x_k + T f(x_k, u_k) (31) without the noise."""
    return x + T * f(x, u, car, mu)


def h(
    x: np.ndarray,
    u: Inputs,
    car: Car,
    mu: float,
    quasi_static: bool = False,
    linear: bool = False,
) -> np.ndarray:
    """y (30): a_x, a_y, γ, ω_i = v_ix (1 + κ̂_i) / R; with quasi_static, x is [v_x, v_y, γ]
    and the lateral forces are G_yκ F_y0 at x (linear tires: see `wheels`)."""
    w = wheels(x, u, car, mu, linear)
    fx, fy, _ = body_forces(x, u, car, w.fy_qs if quasi_static else None)
    om = w.vix * (1 + w.kappa) / car.r_wheel
    return np.concatenate([np.stack([fx / car.m, fy / car.m, x[..., 2]], axis=-1), om], axis=-1)


def step3(x: np.ndarray, u: Inputs, car: Car, T: float, fy: np.ndarray) -> np.ndarray:
    """The 3-state model [v_x, v_y, γ]: (26)'s first three rows with the given lateral
    forces (the quasi-static G_yκ F_y0: (20) at steady state)."""
    fx, fy, mz = body_forces(x, u, car, fy)
    vx, vy, r = x[..., 0], x[..., 1], x[..., 2]
    return x + T * np.stack([fx / car.m + r * vy, fy / car.m - r * vx, mz / car.i_z], axis=-1)


def adaptive_r(u: Inputs, kappa: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """diag R (7) by (66)-(69) from the measurements, δ, F_x and κ̂ at the estimate, each
    within [r/r_clip, r r_clip] of the fixed value (our bound: (69) grows without one)."""
    fixed = fixed_r(p)
    if p["adaptive"] < 0.5:
        return fixed
    ax, ay, gz = (abs(float(v)) for v in u.y[:3])
    dl = abs(u.delta)
    sfx, sk = float(np.abs(u.fx).sum()), float(np.abs(kappa).sum())
    c_ax, c_ay, c_gz, c_w = (
        p[k] * fixed[i] for k, i in (("c_ax", 0), ("c_ay", 1), ("c_gz", 2), ("c_w", 3))
    )
    r_ax = (
        c_ax
        / 3
        * (math.exp(-p["d_ax1"] * ax) + math.exp(-p["d_ax2"] * sfx) + math.exp(-p["d_ax3"] * sk))
    )
    r_ay = c_ay / 2 * (math.exp(-p["d_ay1"] * ay) + math.exp(-p["d_ay2"] * dl))
    r_gz = c_gz / 2 * (math.exp(-p["d_gz1"] * gz) + math.exp(-p["d_gz2"] * dl))
    common = math.exp(p["d_w2"] * ax) + math.exp(p["d_w3"] * ay)
    r_w = c_w / 3 * (np.exp(p["d_w1"] * np.minimum(np.abs(kappa), 1.0)) + common)
    r = np.array([r_ax, r_ay, r_gz, *r_w])
    clip = p["r_clip"]
    return np.clip(r, fixed / clip, fixed * clip)


def fixed_r(p: Mapping[str, float]) -> np.ndarray:
    return np.array([p["r_ax"], p["r_ay"], p["r_gz"], *[p["r_w"]] * 4])


def q_diag(p: Mapping[str, float], n: int = N_X) -> np.ndarray:
    """diag Q of n states: v_x, v_y, γ and, for 7, the forces."""
    forces = [p["q_f"]] * 4 if n == N_X else []
    return np.array([p["q_v"], p["q_vy"], p["q_r"], *forces])


def x0(p: Mapping[str, float], n: int = N_X) -> tuple[np.ndarray, np.ndarray]:
    """Prior mean and covariance of n states (7, or the reduced EKF's 3); the paper gives none."""
    x = np.zeros(n)
    x[0] = p["vx0"]
    forces = [p["p0_f"]] * 4 if n == N_X else []
    return x, np.diag([p["p0_v"], p["p0_lat"], p["p0_lat"] * 0.01, *forces])


def outputs(x: np.ndarray) -> np.ndarray:
    """[v_x, v_y, γ, F_1y..F_4y, β (deg)]."""
    return np.r_[x, math.degrees(math.atan2(x[1], max(x[0], 0.1)))]


def _resist_slope(vx: float, car: Car) -> float:
    return 2 * car.drag * abs(vx) + car.roll * (1 - float(roll_tanh(vx)) ** 2) / 0.5


@dataclass(frozen=True)
class Slopes:
    """∂α_i/∂(v_x, v_y, γ) (4, 3), dκ̂_i/dα_i and d(G_yκ F_y0)_i/dα_i (4 each) at one state."""

    dalpha: np.ndarray
    dk: np.ndarray
    dqs: np.ndarray


def slopes(
    x: np.ndarray, u: Inputs, car: Car, mu: float, w: Wheels, linear: bool = False
) -> Slopes:
    """κ̂'s dependence on α through G_xα (28) included. With z = Bα - E (Bα - atan(Bα)),
    dF_y0/dα = D C cos(C atan z) B (1 - E + E / (1 + (Bα)²)) / (1 + z²). Linear tires:
    see `wheels`."""
    vx, vy, r = x[:3]
    lx, byw = car.lx, car.byw
    d = u.delta * STEERED
    cd, sd = np.cos(d), np.sin(d)
    vX, vY = vx - byw * r, vy + lx * r
    viy = -sd * vX + cd * vY
    den = np.maximum(np.abs(w.vix), 0.5)
    sgn = np.sign(w.vix)
    dalpha, dks, dqss = np.zeros((4, 3)), np.zeros(4), np.zeros(4)
    by, cy, ey = car.b_y, car.c_y, car.e_y
    for i in range(4):
        L = np.array([cd[i], sd[i], -byw[i] * cd[i] + lx[i] * sd[i]])
        dviy = np.array([-sd[i], cd[i], sd[i] * byw[i] + cd[i] * lx[i]])
        dden = sgn[i] * L if abs(w.vix[i]) > 0.5 else np.zeros(3)
        zz = viy[i] / den[i]
        dalpha[i] = -(dviy / den[i] - viy[i] / den[i] ** 2 * dden) / (1 if linear else 1 + zz * zz)
        if linear:
            dqss[i] = by * cy * mu * u.fz[i]
            continue
        a, k = float(w.alpha[i]), float(w.kappa[i])
        ba, bxa, bk = by * a, car.b_xa * a, car.b_yk * k
        # κ̂ = F_x / (G_xα(α) k): dκ̂/dα = -κ̂ G_xα' / G_xα
        cxa, cyk = car.c_xa, car.c_yk
        g_xa = math.cos(cxa * math.atan(bxa))
        dks[i] = k * math.sin(cxa * math.atan(bxa)) * cxa * car.b_xa / (1 + bxa * bxa) / g_xa
        dmax = mu * u.fz[i]
        z = ba - ey * (ba - math.atan(ba))
        f0 = dmax * math.sin(cy * math.atan(z))
        dz = by * (1 - ey + ey / (1 + ba * ba))
        df0 = dmax * cy * math.cos(cy * math.atan(z)) * dz / (1 + z * z)
        g_yk = math.cos(cyk * math.atan(bk))
        dg_yk = -math.sin(cyk * math.atan(bk)) * cyk * car.b_yk / (1 + bk * bk)
        dqss[i] = g_yk * df0 + f0 * dg_yk * dks[i]  # d(G_yκ F_y0)/dα
    return Slopes(dalpha, dks, dqss)


def _omega_rows(u: Inputs, car: Car, w: Wheels, s: Slopes) -> np.ndarray:
    """∂ω_i/∂(v_x, v_y, γ) (4, 3) from (29)."""
    d = u.delta * STEERED
    cd, sd = np.cos(d), np.sin(d)
    L = np.stack([cd, sd, -car.byw * cd + car.lx * sd], axis=-1)
    return (L * (1 + w.kappa[:, None]) + (w.vix * s.dk)[:, None] * s.dalpha) / car.r_wheel


def jacobians(
    x: np.ndarray, u: Inputs, car: Car, mu: float, T: float
) -> tuple[np.ndarray, np.ndarray]:
    """F = I + T ∂f/∂x and H = ∂h/∂x at one state, analytic (`slopes`)."""
    vx, vy, r = x[:3]
    d = u.delta * STEERED
    cd, sd = np.cos(d), np.sin(d)
    w = wheels(x, u, car, mu)
    s = slopes(x, u, car, mu, w)
    m, lx, byw = car.m, car.lx, car.byw
    J = np.zeros((N_X, N_X))
    H = np.zeros((N_Y, N_X))
    J[0, 0] = H[0, 0] = -_resist_slope(vx, car) / m
    J[0, 1], J[0, 2] = r, vy
    J[1, 0], J[1, 2] = -r, -vx
    J[0, 3:] = H[0, 3:] = -sd / m
    J[1, 3:] = H[1, 3:] = cd / m
    J[2, 3:] = (lx * cd + byw * sd) / car.i_z
    H[2, 2] = 1.0
    H[3:, :3] = _omega_rows(u, car, w, s)
    sgn = np.sign(w.vix)
    for i in range(4):
        L = np.array([cd[i], sd[i], -byw[i] * cd[i] + lx[i] * sd[i]])
        q = w.fy_qs[i] - x[3 + i]
        J[3 + i, :3] = (sgn[i] * L * q + abs(w.vix[i]) * s.dqs[i] * s.dalpha[i]) / car.sigma_y
        J[3 + i, 3 + i] = -abs(w.vix[i]) / car.sigma_y
    return np.eye(N_X) + T * J, H


def jacobians3(
    x: np.ndarray, u: Inputs, car: Car, T: float, s: Slopes, w: Wheels | None
) -> tuple[np.ndarray, np.ndarray | None]:
    """The 3-state model's F (3×3) and, given the wheel terms, H (7×3), the forces
    entering through their slopes s."""
    vx, vy, r = x[:3]
    d = u.delta * STEERED
    cd, sd = np.cos(d), np.sin(d)
    dfy = s.dqs[:, None] * s.dalpha  # (4, 3)
    arms = np.stack([-sd, cd, car.lx * cd + car.byw * sd])  # ∂(ΣF_X, ΣF_Y, M_z)/∂F_iy
    Jf = arms @ dfy
    rs = _resist_slope(vx, car) / car.m
    J = np.array([[-rs, r, vy], [-r, 0.0, -vx], [0.0, 0.0, 0.0]])
    J += Jf / np.array([[car.m], [car.m], [car.i_z]])
    if w is None:
        return np.eye(3) + T * J, None
    H = np.zeros((N_Y, 3))
    H[0] = Jf[0] / car.m
    H[0, 0] -= rs
    H[1] = Jf[1] / car.m
    H[2, 2] = 1.0
    H[3:] = _omega_rows(u, car, w, s)
    return np.eye(3) + T * J, H
