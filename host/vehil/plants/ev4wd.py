"""A distributed-drive EV with four in-wheel motors, the ground truth of seed 001.

The car is the plant's own parameters, named as the filters' (vehil.models.ev4wd's
CAR_PARAMS but ω̇'s low-pass, which is the filters' preprocessing); their defaults,
ours (docs/estimators/ev.md), are the shipped car the filters also default to. The
paper gives none and used CarSim. This plant is richer than the filters' 7-state
model, so that the comparison is not model against itself:
- planar body v_x, v_y, γ plus position and heading for the driver; four wheel
  rotations I_w ω̇_i = T_i - R F_ix driven (and braked: regenerative) by the motors;
- the combined-slip MF (13)-(19) on the *true* slip ratio κ_i = (ω_i R - v_ix) /
  max(|v_ix|, 3 m/s) (the floor keeps the wheel ODE stable at 1 ms), F_x quasi-static,
  F_y through the first-order relaxation (20) over `sigma_y`;
- quasi-static load transfer (as the filters' `loads`) from the last step's a_x, a_y;
- aero drag and rolling resistance (3), θ = 0; friction μ is a parameter;
- per-wheel traction control and ABS (the paper's Section 6.3 runs with both): a wheel
  whose |κ| passes 0.12 has its torque limit cut at 4 kN·m/s until |κ| falls below 0.04,
  then restored at 800 N·m/s, which makes the cycling slip of the paper's Figs. 6-7;
- integrated by forward Euler at 1 ms, sampled at the scenario's T.

Manoeuvres (`manoeuvre`), each at `speed` km/h held by a PI speed controller:
0 double lane change: a pure-pursuit driver (preview 0.9 s) on a cosine-blended
  path, `dlc_offset` m over transitions of `dlc_length` m (ISO 3888-1 is 3.5 m over
  ~30 m; the paper gives no geometry);
1 continuous steering: δ = `steer_deg` sin(2π `steer_hz` t) from 1 s, faded in over 1 s;
2 low-μ traction (the paper's Section 6.3, Fig. 6): mild torque for 6 s, then rising
  90 N·m/s per wheel to 400 N·m; TCS limits the spin, which starts about 8 s;
3 low-μ ABS braking (Fig. 7): 80 km/h for 5 s, then a regenerative brake torque of
  60 N·m per wheel with 0.8 s pulses to 450 N·m every 2.5 s that lock the wheels.

Sensors (`noise` = 1, production-like; the paper gives no noise levels): a_x, a_y
σ 0.1 m/s² with biases 0.05 / -0.04 m/s²; γ σ 0.5 °/s with a 0.2 °/s bias; ω_i σ 0.2 rad/s
(resolver); δ σ 0.05°; motor torque σ 2 N·m. All are sampled, noise-free, with
`noise` = 0; `noise` scales the σ (the biases stay).

The car is the plant's own, not the filters' (their model is vehil.models.ev4wd; this
module evaluates its tires itself): a scenario names the car in the plant and, to
match or not, in the estimator. Beyond the filters' model: the longitudinal MF's
curvature `e_x` (the filters take F_x from the motors), a load-sensitive friction
(`load_sens`: μ_eff = μ (1 - load_sens (F_z - F_z0)/F_z0), F_z0 the static load, so a
loaded tire grips less per newton, as real tires do), a longitudinal relaxation length
`sigma_x` (0: quasi-static), and
load transfer through the body's roll and pitch with time constants `roll_tau`,
`pitch_tau` (0: quasi-static, as the filters assume).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import asdict

import numpy as np

from vehil.models import ev4wd as ev
from vehil.plants import register
from vehil.plants.base import PlantSpec, Trace, joined
from vehil.spec import Param, Signal

DT = 1e-3
V_FLOOR = 3.0  # m/s: slip-ratio denominator floor
SLIP_ON, SLIP_OFF = 0.12, 0.04
CUT_RATE, RESTORE_RATE = 4000.0, 800.0  # N·m/s
T_MAX = 600.0  # N·m per motor
PREVIEW_S = 0.9


def dlc_path(x: float, offset: float, length: float) -> float:
    """Lateral position (m) of the lane-change path at distance x: 15 m straight, move
    over in `length`, hold 25 m, move back in `length`."""
    x1, x2 = 15.0, 15.0 + length
    x3, x4 = x2 + 25.0, x2 + 25.0 + length
    if x < x1 or x > x4:
        return 0.0
    if x < x2:
        return offset * 0.5 * (1 - math.cos(math.pi * (x - x1) / length))
    if x < x3:
        return offset
    return offset * 0.5 * (1 + math.cos(math.pi * (x - x3) / length))


def magic_formula(x: np.ndarray, b: float, c: float, e: float, d: np.ndarray) -> np.ndarray:
    """Pacejka's D sin(C atan(B x - E (B x - atan(B x))))."""
    bx = b * x
    return d * np.sin(c * np.arctan(bx - e * (bx - np.arctan(bx))))


def transfer_loads(ax: float, ay: float, car: ev.Car) -> np.ndarray:
    """F_z,i: static plus the steady transfer of the car's body at accelerations ax, ay."""
    m, wb, h = car.m, car.wheelbase, car.h_cg
    front = m * car.g * car.l_r / (2 * wb) - m * ax * h / (2 * wb)
    rear = m * car.g * car.l_f / (2 * wb) + m * ax * h / (2 * wb)
    lat_f = m * ay * h * car.l_r / (car.track * wb)
    lat_r = m * ay * h * car.l_f / (car.track * wb)
    return np.maximum(np.array([front - lat_f, front + lat_f, rear - lat_r, rear + lat_r]), 0.0)


def _lag(tau: float, dt: float) -> float:
    """The share of the way a first-order lag of time constant tau moves in dt (1: none)."""
    return 1.0 if tau <= 0 else 1.0 - math.exp(-dt / tau)


def _stream(
    p: Mapping[str, float], duration: float, T: float, seed: int, chunk: int
) -> Iterator[Trace]:
    rng = np.random.default_rng(seed)
    n = int(round(duration / T))
    sub = max(1, int(round(T / DT)))
    dt = T / sub
    man = int(p["manoeuvre"])
    mu = p["mu"]
    v_set = p["speed"] / 3.6
    vx, vy, r = v_set, 0.0, 0.0
    X, Y, psi = -30.0, 0.0, 0.0  # the lane change starts 30 m + 15 m ahead
    car = ev.Car.of({**asdict(ev.SHIPPED), **p})  # ω̇'s τ: not the plant's
    w = np.full(4, v_set / car.r_wheel)
    fy = np.zeros(4)
    ax = ay = 0.0
    limit = np.full(4, T_MAX)
    cutting = np.zeros(4, bool)
    integ = 0.0
    lx, byw, st = car.lx, car.byw, ev.STEERED
    mass, i_z = car.m, car.i_z
    fz0 = transfer_loads(0.0, 0.0, car)
    fz = fz0.copy()
    fx = np.zeros(4)
    k_roll, k_pitch = _lag(p["roll_tau"], T / sub), _lag(p["pitch_tau"], T / sub)
    ax_l = ay_l = 0.0  # the accelerations the body's pitch and roll have reached
    names = ["ax", "ay", "gz", "w1", "w2", "w3", "w4", "delta", "tq1", "tq2", "tq3", "tq4"]
    tnames = ["vx", "vy", "r", "fy1", "fy2", "fy3", "fy4", "kappa1", "kappa2", "kappa3", "kappa4"]
    sd_in = p["noise"] * np.array(
        [ev.SD_ACC, ev.SD_ACC, ev.SD_GYRO, *[ev.SD_W] * 4, math.radians(0.05), *[2.0] * 4]
    )
    bias = np.zeros(12)
    bias[:3] = (0.05, -0.04, math.radians(0.2))
    for k0 in range(0, n, chunk):
        m = min(chunk, n - k0)
        out = np.zeros((m, 12))
        truth = np.zeros((m, 7 + 4))  # vx vy r fy1..4, kappa1..4
        for k in range(k0, k0 + m):
            for j in range(sub):
                t = (k * sub + j) * dt
                # Driver: steering.
                if man == 0:
                    ahead = max(PREVIEW_S * vx, 5.0)
                    gx = X + ahead
                    gy = dlc_path(gx, p["dlc_offset"], p["dlc_length"])
                    dx, dy = gx - X, gy - Y
                    yb = -math.sin(psi) * dx + math.cos(psi) * dy
                    delta = math.atan(2 * car.wheelbase * yb / (dx * dx + dy * dy))
                elif man == 1:
                    fade = min(max(t - 1.0, 0.0), 1.0)
                    delta = (
                        fade
                        * math.radians(p["steer_deg"])
                        * math.sin(2 * math.pi * p["steer_hz"] * t)
                    )
                else:
                    delta = 0.0
                # Driver: torque demand per wheel.
                if man == 2:
                    demand = 80.0 + 90.0 * max(t - 6.0, 0.0)
                    demand = min(demand, 400.0)
                elif man == 3 and t >= 5.0:
                    demand = -(450.0 if (t - 5.0) % 2.5 < 0.8 else 60.0)
                else:
                    err = v_set - vx
                    integ += err * dt
                    resist = car.drag * vx * vx + car.roll
                    demand = car.r_wheel * (resist + mass * (1.5 * err + 0.3 * integ)) / 4
                # Wheels: kinematics and slips.
                d = delta * st
                cd, sd = np.cos(d), np.sin(d)
                vX, vY = vx - byw * r, vy + lx * r
                vix = cd * vX + sd * vY
                viy = -sd * vX + cd * vY
                alpha = -np.arctan(viy / np.maximum(np.abs(vix), 0.5))
                kappa = (w * car.r_wheel - vix) / np.maximum(np.abs(vix), V_FLOOR)
                # TCS / ABS: cut the torque limit while a wheel slips, restore it after.
                cutting = np.where(np.abs(kappa) > SLIP_ON, True, cutting)
                cutting = np.where(np.abs(kappa) < SLIP_OFF, False, cutting)
                limit = np.clip(limit + np.where(cutting, -CUT_RATE, RESTORE_RATE) * dt, 0.0, T_MAX)
                tq = np.clip(demand, -limit, limit)
                # Loads through the body's pitch and roll, then the tires.
                ax_l += k_pitch * (ax - ax_l)
                ay_l += k_roll * (ay - ay_l)
                fz = transfer_loads(ax_l, ay_l, car)
                dmax = mu * fz * (1.0 - p["load_sens"] * (fz - fz0) / fz0)
                fx0 = magic_formula(kappa, car.b_x, car.c_x, p["e_x"], dmax)
                fx_qs = np.cos(car.c_xa * np.arctan(car.b_xa * alpha)) * fx0
                fy_qs = np.cos(car.c_yk * np.arctan(car.b_yk * kappa)) * magic_formula(
                    alpha, car.b_y, car.c_y, car.e_y, dmax
                )
                if p["sigma_x"] <= 0:
                    fx = fx_qs
                fX, fY = cd * fx - sd * fy, sd * fx + cd * fy
                resist = car.drag * vx * abs(vx) + car.roll * math.tanh(vx / 0.5)
                ax = (fX.sum() - resist) / mass
                ay = fY.sum() / mass
                mz = float((lx * fY - byw * fX).sum())
                if j == 0:
                    out[k - k0] = (ax, ay, r, *w, delta, *tq)
                    truth[k - k0] = (vx, vy, r, *fy, *kappa)
                # Euler step.
                w = np.maximum(w + dt * (tq - car.r_wheel * fx) / car.i_w, 0.0)
                fy = fy + dt * np.abs(vix) / car.sigma_y * (fy_qs - fy)
                if p["sigma_x"] > 0:
                    fx = fx + dt * np.abs(vix) / p["sigma_x"] * (fx_qs - fx)
                vx, vy, r = vx + dt * (ax + r * vy), vy + dt * (ay - r * vx), r + dt * mz / i_z
                X += dt * (vx * math.cos(psi) - vy * math.sin(psi))
                Y += dt * (vx * math.sin(psi) + vy * math.cos(psi))
                psi += dt * r
        if p["noise"] > 0:
            out = out + bias + rng.normal(0.0, 1.0, out.shape) * sd_in
        beta = np.degrees(np.arctan2(truth[:, 1], np.maximum(truth[:, 0], 0.1)))
        yield Trace(
            t=np.arange(k0, k0 + m) * T,
            signals={nm: out[:, i] for i, nm in enumerate(names)},
            truth={**{nm: truth[:, i] for i, nm in enumerate(tnames)}, "beta": beta},
        )


SPEC = register(
    PlantSpec(
        name="ev4wd",
        title="Four-in-wheel-motor EV: body, wheels, combined-slip MF, TCS/ABS (seed 001)",
        params=(
            Param("manoeuvre", "1", default=0, lo=0, hi=3, doc="0 DLC, 1 sine, 2 TCS, 3 ABS"),
            Param("speed", "km/h", default=80.0, lo=5.0, hi=160.0, doc="set speed"),
            Param("mu", "1", default=0.85, lo=0.05, hi=1.2, doc="road friction"),
            Param("dlc_offset", "m", default=3.5, lo=0.0, hi=5.0, doc="lane-change offset"),
            Param("dlc_length", "m", default=30.0, lo=10.0, hi=200.0, doc="transition length"),
            Param(
                "steer_deg", "deg", default=1.5, lo=0.0, hi=20.0, doc="sine amplitude, road wheel"
            ),
            Param("steer_hz", "Hz", default=0.5, lo=0.01, hi=5.0, doc="sine frequency"),
            Param("noise", "1", default=1, lo=0, hi=10, doc="sensor σ × production-like"),
            *(q for q in ev.CAR_PARAMS if q.name != "tau_wdot"),
            Param("e_x", "1", default=0.97, lo=-3.0, hi=1.0, doc="tire MF E_x"),
            Param("load_sens", "1", default=0.0, lo=0.0, hi=0.5, doc="μ's fall per load rise"),
            Param("sigma_x", "m", default=0.0, lo=0.0, hi=3.0, doc="longit. relaxation, 0 none"),
            Param("roll_tau", "s", default=0.0, lo=0.0, hi=2.0, doc="roll lag of load transfer"),
            Param("pitch_tau", "s", default=0.0, lo=0.0, hi=2.0, doc="pitch lag of transfer"),
        ),
        signals=(*ev.INPUTS,),
        truth=(
            *ev.OUTPUTS,
            *(Signal(f"kappa{i}", "1", doc=f"wheel {i} slip ratio") for i in range(1, 5)),
        ),
        simulate=joined(_stream),
        stream=_stream,
    )
)
