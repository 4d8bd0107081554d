"""Seed 003's quarter car (note §1.1, §4.1): the rig and the SIL plant in one.

The nonlinear 2-DOF model with Table 1's parameters, integrated with RK4 on a fine grid
(1 kHz by default) and sampled at the estimator's T; the actuator force is held between
samples. The truth differs from the observers' nominal model (note §4.1 [ASSUMPTION]):
sprung mass, k1 and c1 scaled and a strut Coulomb friction, so estimating uncertainty
means something. Sensors: two accelerometers with a bias drifting within [bias_lo,
bias_hi] (m/s²) and white noise of variance noise_var; displacements are truth only.

Roads (`road`): 0 sinusoid (test 1), 1 pseudo-random multisine in [f_lo, f_hi] (test 2),
2 ISO 8608 class `iso_class` (1 = A ... 8 = H) at `speed_kmh`, as a first-order shaping
filter of white noise (the SIL's random road). A recorded profile replaces them:
`road_profile = "file.csv"` in a scenario's [plant] (columns t [s], x_r [m], linearly
resampled; the last height holds past its end).

Truth signals carry the estimators' names (x_s, v_s, x_us, v_us, x_r, F1, F2) and the
comfort and limit figures (a_body, defl, tire_defl, u_applied).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from vehil.models.quarter_car import NOMINAL, QuarterCar
from vehil.plants import register
from vehil.plants.base import FileInput, PlantSpec, Trace
from vehil.spec import Param, Signal

ISO_GD_N0 = 16e-6  # m³: class A's G_d(n0) at n0 = 0.1 cycle/m; each class is 4x the last
ISO_N0 = 0.1  # cycle/m
ISO_NC = 0.011  # cycle/m: the shaping filter's low corner

RoadFn = Callable[[int], np.ndarray]  # next n values on the fine grid


def truth_model(p: Mapping[str, float]) -> QuarterCar:
    """The plant's car: Table 1 with the configured mismatch."""
    return replace(
        NOMINAL,
        m_s=NOMINAL.m_s * p["ms_scale"],
        k1=NOMINAL.k1 * p["k1_scale"],
        c1=NOMINAL.c1 * p["c1_scale"],
        friction=p["friction"],
        sign_preserving=p["sign_preserving"] >= 0.5,
        lift_off=p["lift_off"] >= 0.5,
    )


def _stream(f: Callable[[np.ndarray], np.ndarray], dt: float) -> RoadFn:
    k = 0

    def take(n: int) -> np.ndarray:
        nonlocal k
        t = (k + np.arange(n)) * dt
        k += n
        return f(t)

    return take


def make_road(p: Mapping[str, Any], dt: float, rng: np.random.Generator) -> RoadFn:
    """The configured road as a stream on the integration grid dt."""
    profile = p.get("road_profile")
    if profile is not None:
        t_rec, h_rec = profile["t"] - profile["t"][0], profile["x_r"]
        return _stream(lambda t: np.interp(t, t_rec, h_rec), dt)
    kind = int(p["road"])
    if kind == 0:
        a, w = p["road_amp"], 2 * math.pi * p["road_freq"]
        return _stream(lambda t: a * np.sin(w * t), dt)
    if kind == 1:
        freqs = np.linspace(p["f_lo"], p["f_hi"], 40)
        phases = rng.uniform(0, 2 * math.pi, len(freqs))
        amp = p["road_rms"] * math.sqrt(2.0 / len(freqs))
        return _stream(
            lambda t: amp * np.sin(2 * math.pi * np.outer(t, freqs) + phases).sum(axis=1), dt
        )
    v = p["speed_kmh"] / 3.6
    gd = ISO_GD_N0 * 4.0 ** (int(p["iso_class"]) - 1)
    a = 2 * math.pi * ISO_NC * v
    phi = math.exp(-a * dt)
    sigma = 2 * math.pi * ISO_N0 * math.sqrt(gd * v) * math.sqrt((1 - phi * phi) / (2 * a))
    state = 0.0

    def take(n: int) -> np.ndarray:
        nonlocal state
        out = np.empty(n)
        w = rng.normal(0.0, sigma * p["road_gain"], n)
        for i in range(n):
            state = phi * state + w[i]
            out[i] = state
        return out

    return take


class QuarterCarLoop:
    """The car stepped one sample at a time: measure(), then apply({"u": force})."""

    def __init__(
        self, p: Mapping[str, Any], T: float, seed: int, road: RoadFn | None = None
    ) -> None:
        self.p, self.T = p, T
        self.car = truth_model(p)
        self.nominal = NOMINAL
        self.sub = max(1, int(round(T / p["dt_int"])))
        self.h = T / self.sub
        self.rng = np.random.default_rng(seed)
        self.road = road or make_road(p, self.h, np.random.default_rng(seed + 7919))
        self.k = 0
        self.x = [0.0, 0.0, 0.0, 0.0]
        self.u = 0.0
        self.r = float(self.road(1)[0])
        # The bias drifts between its bounds with a random phase per sensor.
        self.bias_phase = self.rng.uniform(0, 2 * math.pi, 2)

    def _bias(self, t: float) -> np.ndarray:
        lo, hi = self.p["bias_lo"], self.p["bias_hi"]
        w = 2 * math.pi / self.p["bias_period"]
        return (lo + hi) / 2 + (hi - lo) / 2 * np.sin(w * t + self.bias_phase)

    def measure(self) -> tuple[float, dict[str, float], dict[str, float]]:
        t = self.k * self.T
        x, car, nom = self.x, self.car, self.nominal
        a_s, a_us = car.accelerations(x, self.u, self.r)
        noise = self.rng.normal(0.0, math.sqrt(self.p["noise_var"]), 2)
        bias = self._bias(t)
        signals = {"a_s": a_s + bias[0] + noise[0], "a_us": a_us + bias[1] + noise[1]}
        truth = {
            "x_s": x[0],
            "v_s": x[1],
            "x_us": x[2],
            "v_us": x[3],
            "x_r": self.r,
            "F1": a_s - self.u / nom.m_s,
            "F2": a_us + self.u / nom.m_us,
            "a_body": a_s,
            "a_wheel": a_us,
            "defl": x[0] - x[2],
            "tire_defl": x[2] - self.r,
            "u_applied": self.u,
        }
        return t, signals, truth

    def apply(self, outputs: Mapping[str, float]) -> None:
        self.u = float(outputs.get("u", 0.0))
        road = self.road(self.sub)
        r0 = self.r
        for r1 in road:
            self.x = self.car.rk4(self.x, self.u, r0, float(r1), self.h)
            r0 = float(r1)
        self.r = r0
        self.k += 1


def simulate_with(
    p: Mapping[str, Any],
    duration: float,
    T: float,
    seed: int,
    force: Callable[[float, dict[str, float]], float] | None = None,
    road: RoadFn | None = None,
) -> Trace:
    """Open loop: passive (force None) or a given actuator force u(t, truth)."""
    plant = QuarterCarLoop(p, T, seed, road)
    n = int(round(duration / T))
    t = np.empty(n)
    sig: dict[str, list[float]] = {}
    tru: dict[str, list[float]] = {}
    for k in range(n):
        t[k], s, tr = plant.measure()
        for name, v in s.items():
            sig.setdefault(name, []).append(v)
        for name, v in tr.items():
            tru.setdefault(name, []).append(v)
        plant.apply({"u": force(t[k], tr) if force else 0.0})
    return Trace(
        t=t,
        signals={k: np.array(v) for k, v in sig.items()},
        truth={k: np.array(v) for k, v in tru.items()},
    )


def _simulate(p: Mapping[str, Any], duration: float, T: float, seed: int) -> Trace:
    return simulate_with(p, duration, T, seed)


SPEC = register(
    PlantSpec(
        name="quarter_car",
        title="Nonlinear quarter car with road, mismatch and biased accelerometers (seed 003)",
        params=(
            Param("road", "1", default=0, lo=0, hi=2, doc="0 sine, 1 multisine, 2 ISO 8608"),
            Param("road_amp", "m", default=0.01, lo=0, hi=0.2, doc="sine amplitude"),
            Param("road_freq", "Hz", default=1.5, lo=0.01, hi=30, doc="sine frequency"),
            Param("road_rms", "m", default=0.01, lo=0, hi=0.2, doc="multisine RMS"),
            Param("f_lo", "Hz", default=0.5, lo=0.01, hi=30, doc="multisine lowest line"),
            Param("f_hi", "Hz", default=5.0, lo=0.01, hi=30, doc="multisine highest line"),
            Param("iso_class", "1", default=3, lo=1, hi=8, doc="ISO 8608 class, 1 = A"),
            Param("speed_kmh", "km/h", default=60, lo=1, hi=250, doc="ISO road: speed"),
            Param("road_gain", "1", default=1.0, lo=0, hi=100, doc="ISO road: height scale"),
            Param("ms_scale", "1", default=1.15, lo=0.5, hi=2, doc="true m_s / nominal"),
            Param("k1_scale", "1", default=1.1, lo=0.5, hi=2, doc="true k1 / nominal"),
            Param("c1_scale", "1", default=0.9, lo=0.5, hi=2, doc="true c1 / nominal"),
            Param("friction", "N", default=75.0, lo=0, hi=1000, doc="strut Coulomb friction"),
            Param("sign_preserving", "1", default=0, lo=0, hi=1, doc="1: c2 Δẋ|Δẋ| damper"),
            Param("lift_off", "1", default=0, lo=0, hi=1, doc="1: the tire cannot pull"),
            Param("bias_lo", "m/s^2", default=0.03, lo=-1, hi=1, doc="accelerometer bias min"),
            Param("bias_hi", "m/s^2", default=0.04, lo=-1, hi=1, doc="accelerometer bias max"),
            Param("bias_period", "s", default=60.0, lo=0.1, hi=1e6, doc="bias drift period"),
            Param("noise_var", "m^2/s^4", default=0.01, lo=0, hi=10, doc="accel noise variance"),
            Param("dt_int", "s", default=0.001, lo=1e-5, hi=0.01, doc="RK4 step"),
        ),
        signals=(
            Signal("a_s", "m/s^2", q=16, doc="sprung-mass accelerometer"),
            Signal("a_us", "m/s^2", q=16, doc="unsprung-mass accelerometer"),
        ),
        truth=(
            Signal("x_s", "m", doc="sprung-mass displacement"),
            Signal("v_s", "m/s", doc="sprung-mass velocity"),
            Signal("x_us", "m", doc="unsprung-mass displacement"),
            Signal("v_us", "m/s", doc="unsprung-mass velocity"),
            Signal("x_r", "m", doc="road height under the tire"),
            Signal("F1", "m/s^2", doc="body acceleration less the nominal u/m_s"),
            Signal("F2", "m/s^2", doc="wheel acceleration plus the nominal u/m_us"),
            Signal("a_body", "m/s^2", doc="true body acceleration"),
            Signal("a_wheel", "m/s^2", doc="true wheel acceleration"),
            Signal("defl", "m", doc="suspension deflection x_s - x_us"),
            Signal("tire_defl", "m", doc="tire deflection x_us - x_r"),
            Signal("u_applied", "N", doc="actuator force held over the sample"),
        ),
        simulate=_simulate,
        loop=QuarterCarLoop,
        files=(
            FileInput(
                "road_profile",
                (Signal("t", "s"), Signal("x_r", "m")),
                "a recorded road height profile",
            ),
        ),
        feedback=("u",),
    )
)
