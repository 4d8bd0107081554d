"""A two-wheel-drive car driving straight, as seed 004's ACC speed estimator sees it.

Ground truth is the longitudinal speed v(t) from a drive profile of acceleration,
cruise and braking phases (accelerations change with a 0.15 s lag, as a driver and
powertrain do; the car stops at 0 m/s). The sensors (the patent gives no figures;
ours are a production-grade IMU and wheel-speed sensors):
- accelerometer a_m = a + a_0 + noise (σ 0.10 m/s²), the bias a_0 = b0 + r·a (body
  pitch moves the sensor in proportion to acceleration) + a slow temperature drift
  + g·sin(grade) (the patent counts grade into the bias);
- the two non-driven wheels: ω = v (1 - s) / r_w + noise (σ 0.3 rad/s each), slip
  s = k_slip·|a| while braking (5 % at -4 m/s² on dry road; a larger k_slip and
  lower deceleration model low µ), a small radius mismatch between the wheels;
- the brake switch.

Profiles (parameter `profile`): 0 the mixed drive (cruise, +1.5 m/s²,
cruise, -4 m/s², cruise, -3 m/s² to standstill); 1 a calibration run (±1.2 m/s²
phases of 15 s between 15 s cruises, long enough for the basic filter's bias
estimate to settle; it decelerates without the brake, so the wheels do not slip);
2 hard braking from 100 km/h at -8 m/s² to standstill; 3 braking on low µ from
25 m/s at -2.5 m/s² with high slip.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping

import numpy as np

from vehil.plants import register
from vehil.plants.base import NoiseBlocks, PlantSpec, Trace, chunk_times, joined
from vehil.spec import Param, Signal

G = 9.81
ACCEL_LAG_S = 0.15

# (duration s, commanded acceleration m/s², braking) per phase.
PROFILES: dict[int, tuple[float, tuple[tuple[float, float, bool], ...]]] = {
    0: (
        20.0,
        (
            (10, 0, False),
            (6, 1.5, False),
            (10, 0, False),
            (5, -4.0, True),
            (10, 0, False),
            (4, -3.0, True),
            (5, 0, False),
        ),
    ),
    # Calibration: deceleration by engine braking, no brake and so no wheel slip.
    1: (
        15.0,
        (
            (15, 0, False),
            (15, 1.2, False),
            (15, 0, False),
            (15, -1.2, False),
            (15, 0, False),
            (15, 1.2, False),
            (15, 0, False),
            (15, -1.2, False),
            (15, 0, False),
        ),
    ),
    2: (100 / 3.6, ((5, 0, False), (5, -8.0, True), (3, 0, False))),
    3: (25.0, ((5, 0, False), (12, -2.5, True), (3, 0, False))),
}


def _stream(
    p: Mapping[str, float], duration: float, T: float, seed: int, chunk: int
) -> Iterator[Trace]:
    v0, phases = PROFILES[int(p["profile"])]
    v0 = p["v0"] if p["v0"] > 0 else v0
    n = int(round(duration / T))
    noise = NoiseBlocks(np.random.default_rng(seed), n, 3)  # a_m, omega_l, omega_r
    edges = np.cumsum([0.0] + [ph[0] for ph in phases])
    a_prev, v_prev = 0.0, v0
    alpha = T / (ACCEL_LAG_S + T)
    for t in chunk_times(n, T, chunk):
        m = len(t)
        idx = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, len(phases) - 1)
        a_cmd = np.array([phases[i][1] for i in idx])
        brake = np.array([phases[i][2] for i in idx], dtype=float)
        # Past the profile's end the car cruises.
        a_cmd[t >= edges[-1]] = 0.0
        brake[t >= edges[-1]] = 0.0
        a = np.empty(m)
        v = np.empty(m)
        for k in range(m):
            a_k = a_prev + alpha * (a_cmd[k] - a_prev)
            if v_prev <= 0.0 and a_k < 0.0:  # stopped: brakes hold, nothing moves
                a_k = 0.0
            v_k = max(0.0, v_prev + T * a_k)
            a[k], v[k] = a_k, v_prev
            a_prev, v_prev = a_k, v_k
        moving_brake = brake * (v > 0.05)
        bias = (
            p["bias0"]
            + p["r_pitch"] * a
            + p["drift"] * t / 60.0
            + G * np.sin(np.arctan(p["grade_pct"] / 100.0))
        )
        a_m = a + bias + noise.normal(0, p["accel_noise"], m)
        slip = np.clip(p["k_slip"] * np.abs(a) * moving_brake, 0.0, 0.95)
        r_w = p["r_w"]
        wheel = v * (1.0 - slip) / r_w
        w_l = wheel * (1 + p["radius_mismatch"]) + noise.normal(1, p["wheel_noise"], m)
        w_r = wheel * (1 - p["radius_mismatch"]) + noise.normal(2, p["wheel_noise"], m)
        yield Trace(
            t=t,
            signals={"a_m": a_m, "omega_l": w_l, "omega_r": w_r, "brake": brake, "a": a},
            truth={"v": v, "a0": bias},
        )


SPEC = register(
    PlantSpec(
        name="acc_drive",
        title="Two-wheel-drive car driving straight: accelerometer, non-driven wheels, brake",
        params=(
            Param(
                "profile",
                "1",
                default=0,
                lo=0,
                hi=3,
                doc="0 mixed, 1 calibration, 2 hard braking from 100 km/h, 3 low-µ braking",
            ),
            Param("v0", "m/s", default=0.0, lo=0.0, hi=70.0, doc="initial speed; 0: profile's"),
            Param("r_w", "m", default=0.30, lo=0.1, hi=1.0),
            Param("bias0", "m/s^2", default=0.15, lo=-2.0, hi=2.0),
            Param("r_pitch", "1", default=0.03, lo=-0.5, hi=0.5, doc="bias per m/s² of accel"),
            Param("drift", "m/s^2/min", default=0.002, lo=-0.5, hi=0.5, doc="temperature drift"),
            Param("grade_pct", "%", default=0.0, lo=-30.0, hi=30.0),
            Param("accel_noise", "m/s^2", default=0.10, lo=0.0, hi=2.0),
            Param("wheel_noise", "rad/s", default=0.3, lo=0.0, hi=5.0),
            Param("k_slip", "s^2/m", default=0.0125, lo=0.0, hi=0.2, doc="slip per m/s² braking"),
            Param("radius_mismatch", "1", default=0.001, lo=0.0, hi=0.05),
        ),
        signals=(
            Signal("a_m", "m/s^2"),
            Signal("omega_l", "rad/s"),
            Signal("omega_r", "rad/s"),
            Signal("brake", "1"),
            Signal("a", "m/s^2", doc="true acceleration (for plots)"),
        ),
        truth=(Signal("v", "m/s"), Signal("a0", "m/s^2")),
        simulate=joined(_stream),
        stream=_stream,
    )
)
