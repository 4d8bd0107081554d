"""A braking car for seed 000 (MANF, UIIEKF): single-track model with Burckhardt tires.

States [v_x, v_y, r, ω_f, ω_r] (the paper's eqs. 2-16); the car's parameters are Table 2's
(the Pride) unless the scenario names others (vehil.braking_car).
Readings (docs/estimators/uiiekf.md): braking-positive slip λ = (v - R ω cos α)/v so braking
forces are positive; v̇_y = ... - r v_x (the printed "+ r v_x" is a misprint); and,
by default, the consistent reading of the loads and forces: per-wheel static loads
front W L_r / 2L, rear W L_f / 2L, load transfer with the signed acceleration,
drag moving load rearward, two wheels per axle in the body equations and each
wheel braked with its half of the axle's torque. `printed = 1` switches to eqs.
(5)-(6) and the per-wheel forces with the whole mass as printed.

The tires are Burckhardt's μ(λ) = ψ (c1 (1 - e^{-c2 λ}) - c3 λ), ψ = 0.85 (Table 2), with
Burckhardt's published surface coefficients (the paper gives none, see vehil.braking_car);
μ/λ uses its limit ψ (c1 c2 - c3) as λ -> 0. The model is integrated with Heun's method at 10 kHz
(the paper's DAQ rate; a locked-up wheel's slip dynamics near standstill are stiff).

The car can be one the filters do not know beyond its parameters: tires whose slip
builds over a relaxation length `sigma_x` (m; the slips follow the kinematic ones at
v/σ, as a tire's carcass deflects before it slides; 0: instantaneous, as the filters
assume), load transfer through a pitching body (`pitch_tau`, s) and a brake whose
torque follows the demand through a hydraulic lag (`brake_tau`, s); 0 leaves each out.

Brake torque profiles (`profile`): 0 a hard step, 1 a 0.3 s ramp, 2 ABS-like
cycling that raises the torque until the more slipping wheel passes 0.3 and
releases it below 0.08. Wheel-speed sensors (`sensor`): 0 ω with white noise of variance
0.01 (rad/s)², 1 the paper's real chain (its eq. 45 and Figs. 5-9): a 48-tooth pulse
train sampled at 10 kHz with noise, a 1416 Hz low-pass, sign (with hysteresis), the
frequency of each pulse, ω = 2πf/48, held at the estimator's sample time.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from scipy import signal as sps

from vehil.braking_car import CAR_PARAMS, SURFACE_DOC, SURFACES, Car
from vehil.plants import register
from vehil.plants.base import PlantSpec, Trace
from vehil.spec import Param, Signal

TEETH = 48
DAQ_HZ = 10_000.0
LPF_HZ = 1416.0


def mu_over_slip(slip: float, c: tuple[float, float, float], psi: float) -> float:
    """μ(λ)/λ, with its limit at λ -> 0."""
    c1, c2, c3 = c
    if slip < 1e-6:
        return psi * (c1 * c2 - c3)
    return psi * (c1 * (1 - np.exp(-c2 * slip)) - c3 * slip) / slip


def derivatives(
    x: np.ndarray,
    delta: float,
    torque: float,
    d_x: float,
    c: tuple[float, float, float],
    printed: bool,
    car: Car,
    sigma: float = 0.0,
) -> np.ndarray:
    """ẋ of eqs. (2)-(16); d_x is the signed longitudinal acceleration for the loads.
    x = [v_x, v_y, r, ω_f, ω_r, then the tires' slips s_x, s_y front and rear], which
    relax towards the kinematic slips over `sigma` (m), or are them at 0."""
    v_x, v_y, r, w_f, w_r = x[:5]
    v_x = max(v_x, 0.1)
    m, r_w, L = car.m, car.r_w, car.wheelbase
    n_wheels = 1.0 if printed else 2.0  # wheels per axle in the body equations
    drag = 0.5 * car.rho * car.c_d * car.a_f * v_x**2 * car.h_a / (2 * L)
    static_f, static_r = car.weight * car.l_r / (2 * L), car.weight * car.l_f / (2 * L)
    transfer = m * d_x * car.h_cg / (2 * L)
    if printed:  # eqs. (5)-(6) as printed
        f_zr = transfer + static_f - drag
        f_zf = -transfer + static_r + drag
    else:
        f_zf = static_f - transfer - drag
        f_zr = static_r + transfer + drag
    forces = []
    d_slip = np.zeros(4)
    for i, (w, lever, steer) in enumerate(((w_f, car.l_f, delta), (w_r, -car.l_r, 0.0))):
        v_lat = v_y + lever * r
        v_w = np.hypot(v_lat, v_x)
        alpha = steer - np.arctan2(v_lat, v_x)
        s_x = (v_w - r_w * w * np.cos(alpha)) / v_w  # braking positive
        s_y = r_w * w * np.sin(alpha) / v_w
        if sigma > 0:
            d_slip[2 * i : 2 * i + 2] = (
                v_w / sigma * (np.array([s_x, s_y]) - x[5 + 2 * i : 7 + 2 * i])
            )
            s_x, s_y = x[5 + 2 * i], x[6 + 2 * i]
        k = mu_over_slip(np.hypot(s_x, s_y), c, car.psi)
        forces.append((k * s_x, k * s_y))
    (kx_f, ky_f), (kx_r, ky_r) = forces
    f_xf, f_yf = kx_f * max(f_zf, 0.0), ky_f * max(f_zf, 0.0)
    f_xr, f_yr = kx_r * max(f_zr, 0.0), ky_r * max(f_zr, 0.0)
    cd, sd = np.cos(delta), np.sin(delta)
    dv_x = n_wheels * (-f_xf * cd - f_yf * sd - f_xr) / m + r * v_y
    dv_y = n_wheels * (f_yf * cd - f_xf * sd + f_yr) / m - r * v_x
    dr = n_wheels * (car.l_f * (f_yf * cd - f_xf * sd) - car.l_r * f_yr) / car.i_z
    share = 1.0 / n_wheels  # each wheel of the axle takes its half of the axle's torque
    dw_f = (r_w * f_xf - car.k_b * torque * share) / car.i_w
    dw_r = (r_w * f_xr - (1 - car.k_b) * torque * share) / car.i_w
    return np.array([dv_x, dv_y, dr, dw_f, dw_r, *d_slip])


def _torque(
    profile: int,
    t: float,
    t_brake: float,
    t_max: float,
    abs_state: list[float],
    slip: float,
    dt: float,
) -> float:
    if t < t_brake:
        return 0.0
    if profile == 0:
        return t_max
    if profile == 1:
        return t_max * min(1.0, (t - t_brake) / 0.3)
    # ABS: apply at 10 kN·m/s until the slip passes 0.3, release at 20 kN·m/s below 0.08.
    applying, torque = abs_state
    if slip > 0.3:
        applying = 0.0
    elif slip < 0.08:
        applying = 1.0
    torque = min(t_max, max(0.0, torque + (10_000.0 if applying else -20_000.0) * dt))
    abs_state[:] = [applying, torque]
    return torque


def _pulse_chain(w: np.ndarray, dt: float, rng: np.random.Generator, noise: float) -> np.ndarray:
    """Wheel speed as the paper's DAQ recovers it from a 48-tooth sensor (eq. 45).

    The filtered signal's sign is taken with a little hysteresis (±0.3), or noise near
    a crossing counts extra pulses; between pulses the speed held is capped by the time
    since the last one, so a locked wheel reads zero, as ABS speed logic does."""
    phase = TEETH * np.cumsum(w) * dt
    raw = np.sign(np.sin(phase)) + rng.normal(0.0, noise, len(w))
    b, a = sps.butter(2, LPF_HZ, fs=DAQ_HZ)
    filtered = sps.lfilter(b, a, raw)
    edges = []
    high = filtered[0] > 0
    for k, y in enumerate(filtered):
        if not high and y > 0.3:
            high = True
            edges.append(k)
        elif high and y < -0.3:
            high = False
    t_edge = np.array(edges, dtype=float) * dt
    out = np.zeros(len(w))
    if len(t_edge) >= 2:
        f = 1.0 / np.diff(t_edge)
        t = np.arange(len(w)) * dt
        idx = np.searchsorted(t_edge[1:], t, side="right") - 1
        held = np.where(idx >= 0, f[np.clip(idx, 0, len(f) - 1)], 0.0)
        since = t - t_edge[1:][np.clip(idx, 0, len(f) - 1)]
        held = np.minimum(held, 1.0 / np.maximum(since, dt))
        held[t < t_edge[1]] = f[0]  # before two pulses have come: the first one's frequency
        out = 2 * np.pi * held / TEETH
    return out


def _simulate(p: Mapping[str, float], duration: float, T: float, seed: int) -> Trace:
    rng = np.random.default_rng(seed)
    dt = 1.0 / DAQ_HZ
    n_fine = int(round(duration / dt))
    every = max(1, int(round(T / dt)))
    c = SURFACES[int(p["surface"])][1:]
    car = Car.of(p)
    r_w = car.r_w
    printed = p["printed"] >= 0.5
    profile = int(p["profile"])
    v0 = p["v0_kmh"] / 3.6
    x = np.array([v0, 0.0, 0.0, v0 / r_w, v0 / r_w, 0.0, 0.0, 0.0, 0.0])
    fine = np.empty((n_fine, 5))
    abs_state = [1.0, 0.0]
    d_x = d_load = tq_applied = 0.0
    sigma = p["sigma_x"]
    pitch = 1.0 - np.exp(-dt / p["pitch_tau"]) if p["pitch_tau"] > 0 else 1.0
    hydraulic = 1.0 - np.exp(-dt / p["brake_tau"]) if p["brake_tau"] > 0 else 1.0
    for k in range(n_fine):
        t_k = k * dt
        delta = p["steer_deg"] * np.pi / 180 * np.sin(2 * np.pi * p["steer_hz"] * t_k)
        # One ABS channel on the worse wheel: neither may lock.
        slip = (x[0] - r_w * min(x[3], x[4])) / max(x[0], 0.1)
        tq = _torque(profile, t_k, p["t_brake"], p["torque"], abs_state, slip, dt)
        tq_applied += hydraulic * (tq - tq_applied)
        fine[k] = x[:5]
        if x[0] < 0.3:  # stopped: the wheels and the body hold still
            x = np.array([x[0], 0.0, 0.0, x[0] / r_w, x[0] / r_w, 0.0, 0.0, 0.0, 0.0])
            continue
        d_load += pitch * (d_x - d_load)
        k1 = derivatives(x, delta, tq_applied, d_load, c, printed, car, sigma)
        k2 = derivatives(x + dt * k1, delta, tq_applied, d_load, c, printed, car, sigma)
        d_x = k1[0]
        x = x + dt / 2 * (k1 + k2)
        x[3:5] = np.maximum(x[3:5], 0.0)  # a braked wheel stops, it does not turn back
    if p["sensor"] >= 0.5:
        w_f = _pulse_chain(fine[:, 3], dt, rng, p["pulse_noise"])
        w_r = _pulse_chain(fine[:, 4], dt, rng, p["pulse_noise"])
        meas_f, meas_r = w_f[::every], w_r[::every]
    else:
        sd = np.sqrt(p["wheel_var"])
        meas_f = fine[::every, 3] + rng.normal(0.0, sd, len(fine[::every]))
        meas_r = fine[::every, 4] + rng.normal(0.0, sd, len(fine[::every]))
    coarse = fine[::every]
    t = np.arange(len(coarse)) * T
    return Trace(
        t=t,
        signals={
            "omega_f": meas_f,
            "omega_r": meas_r,
            "braking": (t >= p["t_brake"]).astype(float),
        },
        truth={"v": coarse[:, 0], "omega_f_true": coarse[:, 3], "omega_r_true": coarse[:, 4]},
    )


SPEC = register(
    PlantSpec(
        name="braking",
        title="Braking car, single-track model with Burckhardt tires (seed 000; Table 2's car)",
        params=(
            Param("v0_kmh", "km/h", default=90.0, lo=5.0, hi=180.0, doc="speed at brake onset"),
            Param("surface", "1", default=0, lo=0, hi=6, doc=SURFACE_DOC),
            Param("profile", "1", default=0, lo=0, hi=2, doc="0 step, 1 ramp, 2 ABS cycling"),
            Param("torque", "N*m", default=4000.0, lo=0.0, hi=10_000.0, doc="total brake torque"),
            Param("t_brake", "s", default=0.5, lo=0.0, hi=100.0, doc="brake onset"),
            Param(
                "printed",
                "1",
                default=0,
                lo=0,
                hi=1,
                doc="1: eqs. (5)-(6) and forces as printed; 0: the consistent reading",
            ),
            Param("steer_deg", "deg", default=0.0, lo=0.0, hi=10.0, doc="steering amplitude"),
            Param("steer_hz", "Hz", default=0.5, lo=0.0, hi=5.0),
            Param("sensor", "1", default=0, lo=0, hi=1, doc="0 ω + noise, 1 the pulse chain"),
            Param("wheel_var", "(rad/s)^2", default=0.01, lo=0.0, hi=10.0),
            Param("pulse_noise", "1", default=0.3, lo=0.0, hi=3.0, doc="σ on the ±1 pulses"),
            Param("sigma_x", "m", default=0.0, lo=0.0, hi=2.0, doc="tire relaxation, 0 none"),
            Param("pitch_tau", "s", default=0.0, lo=0.0, hi=2.0, doc="load transfer lag, 0 none"),
            Param("brake_tau", "s", default=0.0, lo=0.0, hi=1.0, doc="brake torque lag, 0 none"),
            *CAR_PARAMS,
        ),
        signals=(Signal("omega_f", "rad/s"), Signal("omega_r", "rad/s"), Signal("braking", "1")),
        truth=(
            Signal("v", "m/s"),
            Signal("omega_f_true", "rad/s"),
            Signal("omega_r_true", "rad/s"),
        ),
        simulate=_simulate,
    )
)
