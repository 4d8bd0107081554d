"""Seed 001's distributed-drive EV: vehicle constants and the filters' 7-state model.

Every vehicle and tire number is the note's §5.2 suggestion (the paper gives none:
note §0.2); the plant (plants/ev4wd.py) uses the same vehicle, so the filters know
it as the paper assumes ("vehicle parameters known"). Wheels 1 FL, 2 FR, 3 RL, 4 RR
(note §1, REC); ISO axes, y left, yaw positive counter-clockwise.

The model (note §2.9, §2.10), vectorised over any leading batch axes so the UPF runs
N × 43 sigma points in one call:
- x = [v_x, v_y, γ, F̃_1y..F̃_4y]; u = (δ, F_1x..F_4x) and the loads F_z,i;
- ẋ from eqs. (1)-(7) and the relaxation (20) with σ_α = k_α0 / k_y0, forward Euler
  at the filter's sample time (note §3 step 1, ASSUME);
- y = h(x, u) = [a_x, a_y, γ, ω_1..ω_4] from (5) and (29) with κ̂_i = F_ix / k_κ0 (28).
The inputs the filters get are the sensors (a_x, a_y, γ, ω_i, δ, motor torques T_i);
`Preprocess` turns them into u: F_ix = (T_i - I_w ω̇_i)/R (21) with ω̇ from a filtered
difference of the measured wheel speed, and the loads from the measured a_x, a_y
(note §5.2's quasi-static transfer).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from vehil.spec import Param, Signal

# Note §5.2 [ASSUME] values.
M = 1400.0  # kg
I_Z = 1900.0  # kg m²
L_F, L_R = 1.10, 1.45  # m, CG to front / rear axle
TRACK = 1.50  # m
H_CG = 0.50  # m
R_W = 0.30  # m, rolling radius
I_W = 1.2  # kg m², wheel + motor
RHO, C_D, AREA = 1.206, 0.30, 2.2
F_ROLL = 0.015
G = 9.81
# MF (13)-(17): pure-slip B, C, E and the combined-slip weights, S_H = 0.
BX, CX, EX = 10.0, 1.9, 0.97
BY, CY, EY = 10.0, 1.3, 0.0
BXA, CXA = 10.0, 1.0
BYK, CYK = 10.0, 1.0
K_ALPHA0, K_Y0 = 60_000.0, 150_000.0  # N/rad, N/m: σ_α = 0.4 m (20)
SIGMA = K_ALPHA0 / K_Y0
WHEELBASE = L_F + L_R
# Wheel centres (l_i, b_i), note §1.
LX = np.array([L_F, L_F, -L_R, -L_R])
BYW = np.array([TRACK / 2, -TRACK / 2, TRACK / 2, -TRACK / 2])
STEERED = np.array([1.0, 1.0, 0.0, 0.0])  # (22): front wheels only
DRAG = 0.5 * RHO * C_D * AREA

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

# Sensor noise of the plant (note §5.2) sets the nominal fixed R.
SD_ACC, SD_GYRO, SD_W = 0.1, math.radians(0.5), 0.2

PARAMS = (
    Param("T", "s", default=0.01, lo=1e-3, hi=0.05, doc="filter sample time"),
    Param("mu", "1", default=0.85, lo=0.05, hi=1.2, doc="road friction (known, §2.7)"),
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
    # 1 / characteristic magnitude (note §5.2's suggestion).
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
# The 7-state filters' own, after PARAMS: the reduced EKF has no force states.
FORCE_PARAMS = (
    Param("p0_f", "N^2", default=4e4, lo=1.0, hi=1e8, doc="P0 of each lateral force"),
    Param("q_f", "N^2", default=2500.0, lo=1e-3, hi=1e7, doc="Q of each F̃_y per step"),
)


def loads(ax: float | np.ndarray, ay: float | np.ndarray) -> np.ndarray:
    """F_z,i (..., 4) from the CG accelerations: static + quasi-static transfer (note §5.2)."""
    ax, ay = np.asarray(ax), np.asarray(ay)
    front = M * G * L_R / (2 * WHEELBASE) - M * ax * H_CG / (2 * WHEELBASE)
    rear = M * G * L_F / (2 * WHEELBASE) + M * ax * H_CG / (2 * WHEELBASE)
    lat_f = M * ay * H_CG * L_R / (TRACK * WHEELBASE)
    lat_r = M * ay * H_CG * L_F / (TRACK * WHEELBASE)
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
    """Sensors -> u (note §8.1 item 2): F_ix = (T_i - I_w ω̇_i)/R with ω̇ the measured
    wheel speed's difference through a first-order low-pass (τ = 20 ms), and F_z from
    the measured accelerations."""

    TAU = 0.02

    def __init__(self, T: float):
        self.T = T
        self.a = T / (self.TAU + T)
        self.w_prev: np.ndarray | None = None
        self.w_dot = np.zeros(4)

    def __call__(self, z: np.ndarray) -> Inputs:
        ax, ay, gz = z[0], z[1], z[2]
        w, delta, tq = z[3:7], z[7], z[8:12]
        if self.w_prev is not None:
            self.w_dot = self.w_dot + self.a * ((w - self.w_prev) / self.T - self.w_dot)
        self.w_prev = w.copy()
        fx = (tq - I_W * self.w_dot) / R_W
        return Inputs(float(delta), fx, loads(ax, ay), np.array([ax, ay, gz, *w]))


@dataclass(frozen=True)
class Wheels:
    """Per-wheel kinematics and tire terms at a batch of states (..., 4 each)."""

    vix: np.ndarray  # L_iᵀ V (11)
    alpha: np.ndarray  # slip angle
    fy_qs: np.ndarray  # G_yκ(κ̂) F_y0(α) (19)
    kappa: np.ndarray  # κ̂ (28)


def wheels(x: np.ndarray, u: Inputs, mu: float, linear: bool = False) -> Wheels:
    """With `linear`, the tires' linear range: α = -v_iy / max(|v_ix|, 0.5),
    F_y = B_y C_y μF_z α and κ̂ = F_x / (B_x C_x μF_z), no combined-slip weights."""
    vx, vy, r = x[..., 0:1], x[..., 1:2], x[..., 2:3]
    d = u.delta * STEERED
    cd, sd = np.cos(d), np.sin(d)
    vX, vY = vx - BYW * r, vy + LX * r  # (8)-(9) in x_R y_R
    vix = cd * vX + sd * vY  # (11)-(12)
    viy = -sd * vX + cd * vY
    zz = viy / np.maximum(np.abs(vix), 0.5)
    dmax = mu * u.fz
    if linear:
        alpha = -zz
        kappa = u.fx / (BX * CX * np.maximum(dmax, 1.0))
        return Wheels(vix, alpha, BY * CY * dmax * alpha, kappa)
    alpha = -np.arctan(zz)
    kappa = u.fx / (weight(alpha, BXA, CXA) * BX * CX * np.maximum(dmax, 1.0))  # (27)-(28)
    fy_qs = weight(kappa, BYK, CYK) * mf(alpha, BY, CY, EY, dmax)
    return Wheels(vix, alpha, fy_qs, kappa)


def body_forces(
    x: np.ndarray, u: Inputs, fy: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """F_x, F_y, M at the CG (4) with the resistances (3), θ = 0, from the tire-frame
    lateral forces fy: the states F̃_iy unless given (the 3-state model's quasi-static ones)."""
    d = u.delta * STEERED
    cd, sd = np.cos(d), np.sin(d)
    fy = x[..., 3:7] if fy is None else fy
    fX = cd * u.fx - sd * fy  # (1)-(2)
    fY = sd * u.fx + cd * fy
    vx = x[..., 0]
    resist = DRAG * vx * np.abs(vx) + M * G * F_ROLL * roll_tanh(vx)
    return fX.sum(-1) - resist, fY.sum(-1), (LX * fY - BYW * fX).sum(-1)


def f(x: np.ndarray, u: Inputs, mu: float) -> np.ndarray:
    """ẋ (26)."""
    fx, fy, mz = body_forces(x, u)
    vx, vy, r = x[..., 0], x[..., 1], x[..., 2]
    w = wheels(x, u, mu)
    dF = np.abs(w.vix) / SIGMA * (w.fy_qs - x[..., 3:7])  # (20)
    return np.concatenate(
        [np.stack([fx / M + r * vy, fy / M - r * vx, mz / I_Z], axis=-1), dF], axis=-1
    )


def step(x: np.ndarray, u: Inputs, mu: float, T: float) -> np.ndarray:
    """x_{k+1} = x_k + T f(x_k, u_k) (31) without the noise."""
    return x + T * f(x, u, mu)


def h(
    x: np.ndarray, u: Inputs, mu: float, quasi_static: bool = False, linear: bool = False
) -> np.ndarray:
    """y (30): a_x, a_y, γ, ω_i = v_ix (1 + κ̂_i) / R; with quasi_static, x is [v_x, v_y, γ]
    and the lateral forces are G_yκ F_y0 at x (linear tires: see `wheels`)."""
    w = wheels(x, u, mu, linear)
    fx, fy, _ = body_forces(x, u, w.fy_qs if quasi_static else None)
    om = w.vix * (1 + w.kappa) / R_W
    return np.concatenate([np.stack([fx / M, fy / M, x[..., 2]], axis=-1), om], axis=-1)


def step3(x: np.ndarray, u: Inputs, T: float, fy: np.ndarray) -> np.ndarray:
    """The 3-state model [v_x, v_y, γ]: (26)'s first three rows with the given lateral
    forces (the quasi-static G_yκ F_y0: (20) at steady state)."""
    fx, fy, mz = body_forces(x, u, fy)
    vx, vy, r = x[..., 0], x[..., 1], x[..., 2]
    return x + T * np.stack([fx / M + r * vy, fy / M - r * vx, mz / I_Z], axis=-1)


def adaptive_r(u: Inputs, kappa: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """diag R (7) by (66)-(69) from the measurements, δ, F_x and κ̂ at the estimate, each
    within [r/r_clip, r r_clip] of the fixed value (note §4 ASSUME: (69) is unbounded)."""
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
    """Prior mean and covariance of n states (7, or the reduced EKF's 3) (note §5.2)."""
    x = np.zeros(n)
    x[0] = p["vx0"]
    forces = [p["p0_f"]] * 4 if n == N_X else []
    return x, np.diag([p["p0_v"], p["p0_lat"], p["p0_lat"] * 0.01, *forces])


def outputs(x: np.ndarray) -> np.ndarray:
    """[v_x, v_y, γ, F_1y..F_4y, β (deg)]."""
    return np.r_[x, math.degrees(math.atan2(x[1], max(x[0], 0.1)))]


def _resist_slope(vx: float) -> float:
    return 2 * DRAG * abs(vx) + M * G * F_ROLL * (1 - float(roll_tanh(vx)) ** 2) / 0.5


@dataclass(frozen=True)
class Slopes:
    """∂α_i/∂(v_x, v_y, γ) (4, 3), dκ̂_i/dα_i and d(G_yκ F_y0)_i/dα_i (4 each) at one state."""

    dalpha: np.ndarray
    dk: np.ndarray
    dqs: np.ndarray


def slopes(x: np.ndarray, u: Inputs, mu: float, w: Wheels, linear: bool = False) -> Slopes:
    """κ̂'s dependence on α through G_xα (28) included. E_y = 0, so
    dF_y0/dα = D C B cos(C atan(Bα)) / (1 + (Bα)²). Linear tires: see `wheels`."""
    vx, vy, r = x[:3]
    d = u.delta * STEERED
    cd, sd = np.cos(d), np.sin(d)
    vX, vY = vx - BYW * r, vy + LX * r
    viy = -sd * vX + cd * vY
    den = np.maximum(np.abs(w.vix), 0.5)
    sgn = np.sign(w.vix)
    dalpha, dks, dqss = np.zeros((4, 3)), np.zeros(4), np.zeros(4)
    for i in range(4):
        L = np.array([cd[i], sd[i], -BYW[i] * cd[i] + LX[i] * sd[i]])
        dviy = np.array([-sd[i], cd[i], sd[i] * BYW[i] + cd[i] * LX[i]])
        dden = sgn[i] * L if abs(w.vix[i]) > 0.5 else np.zeros(3)
        zz = viy[i] / den[i]
        dalpha[i] = -(dviy / den[i] - viy[i] / den[i] ** 2 * dden) / (1 if linear else 1 + zz * zz)
        if linear:
            dqss[i] = BY * CY * mu * u.fz[i]
            continue
        a, k = float(w.alpha[i]), float(w.kappa[i])
        ba, bxa, bk = BY * a, BXA * a, BYK * k
        # κ̂ = F_x / (G_xα(α) k): dκ̂/dα = -κ̂ G_xα' / G_xα
        g_xa = math.cos(CXA * math.atan(bxa))
        dks[i] = k * math.sin(CXA * math.atan(bxa)) * CXA * BXA / (1 + bxa * bxa) / g_xa
        dmax = mu * u.fz[i]
        f0 = dmax * math.sin(CY * math.atan(ba))
        df0 = dmax * CY * BY * math.cos(CY * math.atan(ba)) / (1 + ba * ba)
        g_yk = math.cos(CYK * math.atan(bk))
        dg_yk = -math.sin(CYK * math.atan(bk)) * CYK * BYK / (1 + bk * bk)
        dqss[i] = g_yk * df0 + f0 * dg_yk * dks[i]  # d(G_yκ F_y0)/dα
    return Slopes(dalpha, dks, dqss)


def _omega_rows(u: Inputs, w: Wheels, s: Slopes) -> np.ndarray:
    """∂ω_i/∂(v_x, v_y, γ) (4, 3) from (29)."""
    d = u.delta * STEERED
    cd, sd = np.cos(d), np.sin(d)
    L = np.stack([cd, sd, -BYW * cd + LX * sd], axis=-1)
    return (L * (1 + w.kappa[:, None]) + (w.vix * s.dk)[:, None] * s.dalpha) / R_W


def jacobians(x: np.ndarray, u: Inputs, mu: float, T: float) -> tuple[np.ndarray, np.ndarray]:
    """F = I + T ∂f/∂x and H = ∂h/∂x at one state, analytic (`slopes`)."""
    vx, vy, r = x[:3]
    d = u.delta * STEERED
    cd, sd = np.cos(d), np.sin(d)
    w = wheels(x, u, mu)
    s = slopes(x, u, mu, w)
    J = np.zeros((N_X, N_X))
    H = np.zeros((N_Y, N_X))
    J[0, 0] = H[0, 0] = -_resist_slope(vx) / M
    J[0, 1], J[0, 2] = r, vy
    J[1, 0], J[1, 2] = -r, -vx
    J[0, 3:] = H[0, 3:] = -sd / M
    J[1, 3:] = H[1, 3:] = cd / M
    J[2, 3:] = (LX * cd + BYW * sd) / I_Z
    H[2, 2] = 1.0
    H[3:, :3] = _omega_rows(u, w, s)
    sgn = np.sign(w.vix)
    for i in range(4):
        L = np.array([cd[i], sd[i], -BYW[i] * cd[i] + LX[i] * sd[i]])
        q = w.fy_qs[i] - x[3 + i]
        J[3 + i, :3] = (sgn[i] * L * q + abs(w.vix[i]) * s.dqs[i] * s.dalpha[i]) / SIGMA
        J[3 + i, 3 + i] = -abs(w.vix[i]) / SIGMA
    return np.eye(N_X) + T * J, H


def jacobians3(
    x: np.ndarray, u: Inputs, T: float, s: Slopes, w: Wheels | None
) -> tuple[np.ndarray, np.ndarray | None]:
    """The 3-state model's F (3×3) and, given the wheel terms, H (7×3), the forces
    entering through their slopes s."""
    vx, vy, r = x[:3]
    d = u.delta * STEERED
    cd, sd = np.cos(d), np.sin(d)
    dfy = s.dqs[:, None] * s.dalpha  # (4, 3)
    arms = np.stack([-sd, cd, LX * cd + BYW * sd])  # ∂(ΣF_X, ΣF_Y, M_z)/∂F_iy
    Jf = arms @ dfy
    rs = _resist_slope(vx) / M
    J = np.array([[-rs, r, vy], [-r, 0.0, -vx], [0.0, 0.0, 0.0]])
    J += Jf / np.array([[M], [M], [I_Z]])
    if w is None:
        return np.eye(3) + T * J, None
    H = np.zeros((N_Y, 3))
    H[0] = Jf[0] / M
    H[0, 0] -= rs
    H[1] = Jf[1] / M
    H[2, 2] = 1.0
    H[3:] = _omega_rows(u, w, s)
    return np.eye(3) + T * J, H
