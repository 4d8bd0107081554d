"""Seed 003's quarter car (the paper's eqs. 1-3): the rig and the SIL plant in one.

The nonlinear 2-DOF model with Table 1's parameters, integrated with RK4 on a fine grid
(1 kHz by default) and sampled at the estimator's T; the actuator force is held between
samples. The truth differs from the observers' nominal model (our choice: the paper names
friction, unmodelled dynamics and sprung-mass variation as the model's uncertainties but
gives no sizes): sprung mass, k1 and c1 scaled and a strut Coulomb friction, so estimating
uncertainty means something. Sensors: two accelerometers with a bias drifting within
[bias_lo, bias_hi] (m/s²) and white noise of variance noise_var; displacements are truth
only.

The car is plants/quarter_car_truth.py's: its own equations, with what the observers'
model lacks (Dahl strut friction, stops, tire damping, progressive tire, enveloping,
actuator lag) and every coefficient scaled from Table 1. The accelerometers have a scale
error `acc_scale` and a first-order bandwidth `acc_bw` (0: ideal) besides bias and noise.

Roads (`road`): 0 sinusoid (test 1), 1 pseudo-random multisine in [f_lo, f_hi] (test 2),
2 ISO 8608 class `iso_class` (1 = A ... 8 = H) at `speed_kmh`, as a first-order shaping
filter of white noise (the SIL's random road), 3 half-sine bumps `bump_h` high and
`bump_len` long every `bump_every` m at `speed_kmh`, 4 a linear chirp of `road_amp` from
f_lo to f_hi over `chirp_s`, repeated. A recorded profile replaces them:
`road_profile = "file.csv"` in a scenario's [plant] (columns t [s], x_r [m], linearly
resampled; the last height holds past its end).

Truth signals carry the estimators' names (x_s, v_s, x_us, v_us, x_r, F1, F2) and the
comfort and limit figures (a_body, defl, tire_defl, u_applied).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping
from typing import Any

import numpy as np

from vehil.errors import PlantLimit
from vehil.models.quarter_car import NOMINAL
from vehil.plants import register
from vehil.plants.base import FileInput, PlantSpec, Trace, join, joined
from vehil.plants.quarter_car_truth import truth_car
from vehil.spec import Param, Signal

ISO_GD_N0 = 16e-6  # m³: class A's G_d(n0) at n0 = 0.1 cycle/m; each class is 4x the last
ISO_N0 = 0.1  # cycle/m
ISO_NC = 0.011  # cycle/m: the shaping filter's low corner

RoadFn = Callable[[int], np.ndarray]  # next n values on the fine grid


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
    if kind == 3:
        h, length, every = p["bump_h"], p["bump_len"], max(p["bump_every"], p["bump_len"])

        def bumps(t: np.ndarray) -> np.ndarray:
            s = np.mod(t * v, every)
            return np.where(s < length, h * np.sin(math.pi * s / length), 0.0)

        return _stream(bumps, dt)
    if kind == 4:
        a, f0, f1, ts = p["road_amp"], p["f_lo"], p["f_hi"], p["chirp_s"]

        def chirp(t: np.ndarray) -> np.ndarray:
            tm = np.mod(t, ts)
            return a * np.sin(2 * math.pi * (f0 * tm + 0.5 * (f1 - f0) / ts * tm * tm))

        return _stream(chirp, dt)
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


def enveloped(road: RoadFn, n: int) -> RoadFn:
    """The road under a tire whose contact patch spans n grid points: their moving average."""
    if n <= 1:
        return road
    window = np.zeros(0)

    def take(m: int) -> np.ndarray:
        nonlocal window
        x = np.concatenate([window, road(m)])
        if len(x) < n:  # the start: the patch sits on the first height
            x = np.concatenate([np.full(n - len(x), x[0]), x])
        c = np.cumsum(np.concatenate([[0.0], x]))
        window = x[-(n - 1) :]
        return (c[n:] - c[:-n])[-m:] / n

    return take


class QuarterCarLoop:
    """The car stepped one sample at a time: measure(), then apply({"u": force})."""

    def __init__(
        self, p: Mapping[str, Any], T: float, seed: int, road: RoadFn | None = None
    ) -> None:
        self.p, self.T = p, T
        self.car = truth_car(p)
        self.nominal = NOMINAL
        self.sub = max(1, int(round(T / p["dt_int"])))
        self.h = T / self.sub
        self.rng = np.random.default_rng(seed)
        road = road or make_road(p, self.h, np.random.default_rng(seed + 7919))
        patch = int(round(p["patch_len"] / max(p["speed_kmh"] / 3.6, 1e-3) / self.h))
        self.road = enveloped(road, patch)
        self.k = 0
        self.x = [0.0] * self.car.n_states
        self.u = 0.0
        self.r = float(self.road(1)[0])
        self.r_dot = 0.0
        # The accelerometers' first-order bandwidth, run on the integration grid.
        bw = p["acc_bw"]
        self.acc_keep = math.exp(-2 * math.pi * bw * self.h) if bw > 0 else 0.0
        self.acc = [0.0, 0.0]
        # The bias drifts between its bounds with a random phase per sensor.
        self.bias_phase = self.rng.uniform(0, 2 * math.pi, 2)

    def _bias(self, t: float) -> np.ndarray:
        lo, hi = self.p["bias_lo"], self.p["bias_hi"]
        w = 2 * math.pi / self.p["bias_period"]
        return (lo + hi) / 2 + (hi - lo) / 2 * np.sin(w * t + self.bias_phase)

    def measure(self) -> tuple[float, dict[str, float], dict[str, float]]:
        t = self.k * self.T
        x, car, nom = self.x, self.car, self.nominal
        a_s, a_us = car.accelerations(x, self.u, self.r, self.r_dot)
        if self.acc_keep == 0.0:
            self.acc = [a_s, a_us]
        noise = self.rng.normal(0.0, math.sqrt(self.p["noise_var"]), 2)
        bias = self._bias(t)
        scale = self.p["acc_scale"]
        signals = {
            "a_s": scale * self.acc[0] + bias[0] + noise[0],
            "a_us": scale * self.acc[1] + bias[1] + noise[1],
        }
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
        for i, r1 in enumerate(road):
            try:
                self.x = self.car.step(self.x, self.u, r0, float(r1), self.h)
            except PlantLimit as exc:
                raise PlantLimit(
                    f"quarter_car at t = {(self.k + i / self.sub) * self.T:.3f} s: {exc}"
                ) from None
            self.r_dot = (float(r1) - r0) / self.h
            r0 = float(r1)
            if self.acc_keep:
                a = self.car.accelerations(self.x, self.u, r0, self.r_dot)
                self.acc = [a[i] + self.acc_keep * (self.acc[i] - a[i]) for i in range(2)]
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
    return join(stream_with(p, duration, T, seed, 1 << 16, force, road))


def stream_with(
    p: Mapping[str, Any],
    duration: float,
    T: float,
    seed: int,
    chunk: int,
    force: Callable[[float, dict[str, float]], float] | None = None,
    road: RoadFn | None = None,
) -> Iterator[Trace]:
    """simulate_with's drive, `chunk` samples at a time."""
    plant = QuarterCarLoop(p, T, seed, road)
    n = int(round(duration / T))
    for k0 in range(0, n, chunk):
        t = np.empty(min(chunk, n - k0))
        sig: dict[str, list[float]] = {}
        tru: dict[str, list[float]] = {}
        for k in range(len(t)):
            t[k], s, tr = plant.measure()
            for name, v in s.items():
                sig.setdefault(name, []).append(v)
            for name, v in tr.items():
                tru.setdefault(name, []).append(v)
            plant.apply({"u": force(t[k], tr) if force else 0.0})
        yield Trace(
            t=t,
            signals={k: np.array(v) for k, v in sig.items()},
            truth={k: np.array(v) for k, v in tru.items()},
        )


def _passive(
    p: Mapping[str, Any], duration: float, T: float, seed: int, chunk: int
) -> Iterator[Trace]:
    return stream_with(p, duration, T, seed, chunk)


SPEC = register(
    PlantSpec(
        name="quarter_car",
        title="Nonlinear quarter car with road, mismatch and biased accelerometers (seed 003)",
        params=(
            Param("road", "1", default=0, lo=0, hi=4, doc="0 sine 1 multi 2 ISO 3 bumps 4 chirp"),
            Param("road_amp", "m", default=0.01, lo=0, hi=0.2, doc="sine amplitude"),
            Param("road_freq", "Hz", default=1.5, lo=0.01, hi=30, doc="sine frequency"),
            Param("road_rms", "m", default=0.01, lo=0, hi=0.2, doc="multisine RMS"),
            Param("f_lo", "Hz", default=0.5, lo=0.01, hi=30, doc="multisine lowest line"),
            Param("f_hi", "Hz", default=5.0, lo=0.01, hi=30, doc="multisine highest line"),
            Param("iso_class", "1", default=3, lo=1, hi=8, doc="ISO 8608 class, 1 = A"),
            Param("speed_kmh", "km/h", default=60, lo=1, hi=250, doc="ISO road: speed"),
            Param("road_gain", "1", default=1.0, lo=0, hi=100, doc="ISO road: height scale"),
            Param("bump_h", "m", default=0.03, lo=0, hi=0.3, doc="bumps: height"),
            Param("bump_len", "m", default=0.5, lo=0.05, hi=20, doc="bumps: length"),
            Param("bump_every", "m", default=15.0, lo=0.05, hi=1000, doc="bumps: spacing"),
            Param("chirp_s", "s", default=20.0, lo=0.1, hi=1e4, doc="chirp: sweep time"),
            Param("ms_scale", "1", default=1.15, lo=0.5, hi=2, doc="true m_s / nominal"),
            Param("mus_scale", "1", default=1.0, lo=0.5, hi=2, doc="true m_us / nominal"),
            Param("k1_scale", "1", default=1.1, lo=0.5, hi=2, doc="true k1 / nominal"),
            Param("knl_scale", "1", default=1.0, lo=0, hi=3, doc="true k2, k3 / nominal"),
            Param("c1_scale", "1", default=0.9, lo=0.5, hi=2, doc="true c1 / nominal"),
            Param("c2_scale", "1", default=1.0, lo=0, hi=3, doc="true c2 / nominal"),
            Param("kus_scale", "1", default=1.0, lo=0.5, hi=2, doc="true k_us / nominal"),
            Param("friction", "N", default=75.0, lo=0, hi=1000, doc="strut Coulomb friction"),
            Param(
                "friction_k", "N/m", default=0, lo=0, hi=1e5, doc="Dahl presliding stiffness, 0 off"
            ),
            Param("sign_preserving", "1", default=0, lo=0, hi=1, doc="1: c2 Δẋ|Δẋ| damper"),
            Param(
                "damper_hold",
                "1",
                default=1,
                lo=0,
                hi=1,
                doc="1: the literal damper holds its peak compression force past c1/2c2",
            ),
            Param("lift_off", "1", default=0, lo=0, hi=1, doc="1: the tire cannot pull"),
            Param(
                "jump_max",
                "m",
                default=1.0,
                lo=0.01,
                hi=100,
                doc="the wheel this far above the road ends the drive (PlantLimit)",
            ),
            Param("stop_gap", "m", default=0, lo=0, hi=0.5, doc="stops past ±gap, 0 off"),
            Param("k_stop", "N/m^2", default=5e6, lo=0, hi=1e9, doc="stop stiffness"),
            Param("c_tire", "N s/m", default=0, lo=0, hi=5000, doc="tire damping"),
            Param("tire_prog", "1/m", default=0, lo=0, hi=50, doc="tire progressive stiffness"),
            Param("patch_len", "m", default=0, lo=0, hi=1, doc="tire contact patch, 0 point"),
            Param("u_lag", "s", default=0, lo=0, hi=1, doc="actuator force lag, 0 none"),
            Param("acc_scale", "1", default=1.0, lo=0.5, hi=1.5, doc="accelerometer scale"),
            Param("acc_bw", "Hz", default=0, lo=0, hi=5000, doc="accelerometer bandwidth, 0 ideal"),
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
        simulate=joined(_passive),
        stream=_passive,
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
