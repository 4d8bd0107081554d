"""The quarter car the `quarter_car` plant simulates: its own equations, richer than the
observers' model (vehil.models.quarter_car), so that estimating a car means estimating one
the filter does not know exactly.

What the truth has that the observers' nominal model has not (each off at its default
unless noted, so the shipped drives keep their car):
- every coefficient of its own: m_s, m_us, k1, k2/k3, c1, c2, k_us scaled from Table 1;
- strut friction: Coulomb smoothed by tanh (`friction`, on by default), or Dahl's model
  with a presliding stiffness `friction_k` (N/m): the strut sticks until the force
  passes the Coulomb level, then slides (a friction state, dF/dt = σ0 (Δẋ - |Δẋ| F/F_c));
- the literal-square damper holding its peak compression force past c1/2c2 (`damper_hold`,
  on by default: the paper's law pushes past c1/c2 and a rough road sent it to NaN);
- bump and rebound stops past ±`stop_gap` (m): a progressive k_stop (|Δx| - gap)²;
- a tire with damping `c_tire`, progressive stiffness (f = k_us δ (1 - `tire_prog` δ):
  stiffer in compression, its peak held in extension) and lift-off (it cannot pull the
  wheel down past its preload);
- a tire that envelops the road over its contact patch `patch_len` (m) at `speed_kmh`
  (a moving average of the road over the patch);
- the actuator force reaching the car through a first-order lag `u_lag` (s).
The sensors (in plants/quarter_car.py) add scale errors and a bandwidth to the bias and
noise. Coordinates from static equilibrium, u as in eqs. (4)-(5).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from vehil.errors import PlantLimit
from vehil.models.quarter_car import NOMINAL

G = 9.81
RATE_STEP = 1.0  # RK4 step times the fastest rate: well inside stability (~2.8)
MAX_PARTS = 1000  # RK4 steps in one integration step before the drive is refused
PAST_THE_CAR = (
    "the drive is past what this car can model; lower the speed or the road class, or give it "
    "stops (stop_gap) and lift_off"
)


@dataclass(frozen=True)
class TruthCar:
    m_s: float
    m_us: float
    k1: float
    k2: float
    k3: float
    c1: float
    c2: float
    k_us: float
    friction: float = 0.0  # N, Coulomb level
    friction_v: float = 0.01  # m/s: tanh smoothing (friction_k = 0)
    friction_k: float = 0.0  # N/m: Dahl presliding stiffness, 0 = smoothed Coulomb
    sign_preserving: bool = False
    damper_hold: bool = True
    lift_off: bool = False
    jump_max: float = 1.0  # m: the wheel this far above the road ends the drive
    stop_gap: float = 0.0  # m, 0 = no stops
    k_stop: float = 0.0  # N/m²
    c_tire: float = 0.0  # N s/m
    tire_prog: float = 0.0  # 1/m
    u_lag: float = 0.0  # s

    @property
    def n_states(self) -> int:
        """x_s, ẋ_s, x_us, ẋ_us, the Dahl friction force, the force the actuator delivers."""
        return 6

    def spring(self, dx: float) -> float:
        f = dx * (self.k1 + dx * (self.k2 + self.k3 * dx))
        past = abs(dx) - self.stop_gap
        if self.stop_gap > 0.0 and past > 0.0:
            f += math.copysign(self.k_stop * past * past, dx)
        return f

    def damper(self, dv: float) -> float:
        if self.sign_preserving:
            return self.c1 * dv + self.c2 * dv * abs(dv)
        if self.damper_hold and self.c2 > 0.0 and dv < -self.c1 / (2.0 * self.c2):
            # Past its peak the literal square would weaken and, past c1/c2, push: the
            # valve holds the peak compression force instead (a blow-off).
            return -self.c1 * self.c1 / (4.0 * self.c2)
        return self.c1 * dv + self.c2 * dv * dv

    def friction_force(self, x: list[float], dv: float) -> float:
        if self.friction_k > 0.0:
            return x[4]
        if self.friction:
            return self.friction * math.tanh(dv / self.friction_v)
        return 0.0

    def tire(self, x_us: float, v_us: float, r: float, r_dot: float) -> float:
        """The force the tire pulls the wheel down with (f_st of eq. 3 and more)."""
        d = x_us - r
        if self.tire_prog > 0.0:
            # Past its peak the progressive law would push a wheel up the further it is
            # above the road: it holds the peak instead.
            d = min(d, 0.5 / self.tire_prog)
        f = self.k_us * d * (1.0 - self.tire_prog * d) + self.c_tire * (v_us - r_dot)
        if self.lift_off:
            f = min(f, (self.m_s + self.m_us) * G)
        return f

    def deriv(self, x: list[float], u: float, r: float, r_dot: float) -> list[float]:
        dx, dv = x[0] - x[2], x[1] - x[3]
        strut = self.spring(dx) + self.damper(dv) + self.friction_force(x, dv)
        force = x[5] if self.u_lag > 0.0 else u
        a_s = (-strut + force) / self.m_s
        a_us = (strut - self.tire(x[2], x[3], r, r_dot) - force) / self.m_us
        d_fr = 0.0
        if self.friction_k > 0.0 and self.friction > 0.0:
            d_fr = self.friction_k * (dv - abs(dv) * x[4] / self.friction)
        d_u = (u - x[5]) / self.u_lag if self.u_lag > 0.0 else 0.0
        return [x[1], a_s, x[3], a_us, d_fr, d_u]

    def accelerations(
        self, x: list[float], u: float, r: float, r_dot: float
    ) -> tuple[float, float]:
        d = self.deriv(x, u, r, r_dot)
        return d[1], d[3]

    def rate(self, x: list[float], r: float) -> float:
        """A bound on the fastest local rate (1/s) of the car at x: the wheel's natural
        frequency on every stiffness it touches, its damping rate, the Dahl friction's
        relaxation σ0 |Δẋ| / F_c and the actuator's lag."""
        dx, dv = x[0] - x[2], x[1] - x[3]
        k = abs(self.k1 + dx * (2.0 * self.k2 + 3.0 * self.k3 * dx)) + self.k_us * (
            1.0 + 2.0 * self.tire_prog * abs(x[2] - r)
        )
        past = abs(dx) - self.stop_gap
        if self.stop_gap > 0.0 and past > 0.0:
            k += 2.0 * self.k_stop * past
        c = abs(self.c1 + 2.0 * self.c2 * dv) + self.c_tire
        relax = 0.0
        if self.friction_k > 0.0 and self.friction > 0.0:
            k += self.friction_k
            relax = self.friction_k * abs(dv) / self.friction
        elif self.friction:
            c += self.friction / self.friction_v
        m = min(self.m_s, self.m_us)
        lag = 1.0 / self.u_lag if self.u_lag > 0.0 else 0.0
        return max(math.sqrt(k / m), c / m, relax, lag)

    def step(self, x: list[float], u: float, r0: float, r1: float, h: float) -> list[float]:
        """x after h with u held and the road linear from r0 to r1: RK4 in as many equal
        parts as keep h_part times the car's fastest rate at x within RATE_STEP (explicit
        RK4 leaves its stability region past ~2.8), so a stiff stop or Dahl friction is
        integrated as finely as it needs. Raises PlantLimit when that would take more than
        MAX_PARTS parts or the state stops being finite."""
        parts = math.ceil(h * self.rate(x, r0) / RATE_STEP) if _finite(x) else 1
        if parts > MAX_PARTS:
            raise PlantLimit(
                f"the quarter car needs {parts} RK4 steps in one {h:g} s step "
                f"(fastest rate {self.rate(x, r0):.3g} 1/s at deflection {x[0] - x[2]:+.3f} m, "
                f"Δẋ {x[1] - x[3]:+.2f} m/s): {PAST_THE_CAR}"
            )
        hp = h / parts
        for i in range(parts):
            x = self.rk4(x, u, r0 + (r1 - r0) * i / parts, r0 + (r1 - r0) * (i + 1) / parts, hp)
        if not _finite(x):
            raise PlantLimit(f"the quarter car's state stopped being finite: {PAST_THE_CAR}")
        if x[2] - r1 > self.jump_max:
            raise PlantLimit(
                f"the wheel is {x[2] - r1:.2f} m above the road (jump_max {self.jump_max:g} m):"
                " a car that jumps like that leaves the road, which a quarter car cannot "
                "model (without lift_off its tire pulls it back); lower the speed or the "
                "road class"
            )
        return x

    def rk4(self, x: list[float], u: float, r0: float, r1: float, h: float) -> list[float]:
        """One RK4 step of h with u held and the road linear from r0 to r1."""
        rm, rd = 0.5 * (r0 + r1), (r1 - r0) / h
        n = len(x)
        k1 = self.deriv(x, u, r0, rd)
        k2 = self.deriv([x[i] + 0.5 * h * k1[i] for i in range(n)], u, rm, rd)
        k3 = self.deriv([x[i] + 0.5 * h * k2[i] for i in range(n)], u, rm, rd)
        k4 = self.deriv([x[i] + h * k3[i] for i in range(n)], u, r1, rd)
        return [x[i] + h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]) for i in range(n)]


def _finite(x: list[float]) -> bool:
    return all(math.isfinite(v) for v in x)


def truth_car(p: Mapping[str, float]) -> TruthCar:
    """Table 1 with the plant's mismatch applied."""
    n = NOMINAL
    return TruthCar(
        m_s=n.m_s * p["ms_scale"],
        m_us=n.m_us * p["mus_scale"],
        k1=n.k1 * p["k1_scale"],
        k2=n.k2 * p["knl_scale"],
        k3=n.k3 * p["knl_scale"],
        c1=n.c1 * p["c1_scale"],
        c2=n.c2 * p["c2_scale"],
        k_us=n.k_us * p["kus_scale"],
        friction=p["friction"],
        friction_k=p["friction_k"],
        sign_preserving=p["sign_preserving"] >= 0.5,
        damper_hold=p["damper_hold"] >= 0.5,
        lift_off=p["lift_off"] >= 0.5,
        jump_max=p["jump_max"],
        stop_gap=p["stop_gap"],
        k_stop=p["k_stop"],
        c_tire=p["c_tire"],
        tire_prog=p["tire_prog"],
        u_lag=p["u_lag"],
    )
