"""A braking car for seed 000 (MANF, UIIEKF): single-track model with Burckhardt tires.

States [v_x, v_y, r, ω_f, ω_r] (note §1, eqs. 2-16), Table 2 parameters (Pride).
Readings (note §1.3-1.6): braking-positive slip λ = (v - R ω cos α)/v so braking
forces are positive; v̇_y = ... - r v_x (the printed "+ r v_x" is a misprint); and,
by default, the consistent reading of the loads and forces: per-wheel static loads
front W L_r / 2L, rear W L_f / 2L, load transfer with the signed acceleration,
drag moving load rearward, two wheels per axle in the body equations and each
wheel braked with its half of the axle's torque. `printed = 1` switches to eqs.
(5)-(6) and the per-wheel forces with the whole mass as printed.

The tires are Burckhardt's μ(λ) = ψ (c1 (1 - e^{-c2 λ}) - c3 λ), ψ = 0.85, with the
surface table of note §1.5 (the paper gives no coefficients); μ/λ uses its limit
ψ (c1 c2 - c3) as λ -> 0. The model is integrated with Heun's method at 10 kHz
(the paper's DAQ rate; a locked-up wheel's slip dynamics near standstill are stiff).

Brake torque profiles (`profile`): 0 a hard step, 1 a 0.3 s ramp, 2 ABS-like
cycling that raises the torque until the more slipping wheel passes 0.3 and
releases it below 0.08. Wheel-speed sensors (`sensor`): 0 ω with white noise of variance
0.01 (rad/s)², 1 the real chain of note §4.1: a 48-tooth pulse train sampled at
10 kHz with noise, a 1416 Hz low-pass, sign (with hysteresis), the frequency
of each pulse,
ω = 2πf/48, held at the estimator's sample time.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from scipy import signal as sps

from vehil.estimators.base import Param, Signal
from vehil.plants import register
from vehil.plants.base import PlantSpec, Trace

# Table 2.
M, R_W, I_W, PSI, H, W = 850.0, 0.27, 4.15, 0.85, 0.57, 8330.0
RHO, L_R, L_F, I_Z, K_B, C_D, H_A, A_F = 1.027, 1.425, 0.92, 1627.0, 0.7, 0.32, 1.16, 1.87
L = L_F + L_R
TEETH = 48
DAQ_HZ = 10_000.0
LPF_HZ = 1416.0

# Burckhardt (c1, c2, c3) by surface (note §1.5; literature values, not the paper's).
SURFACES = {
    0: ("dry asphalt", 1.2801, 23.99, 0.52),
    1: ("wet asphalt", 0.857, 33.822, 0.347),
    2: ("dry concrete", 1.1973, 25.168, 0.5373),
    3: ("dry cobblestone", 1.3713, 6.4565, 0.6691),
    4: ("wet cobblestone", 0.4004, 33.708, 0.1204),
    5: ("snow", 0.1946, 94.129, 0.0646),
    6: ("ice", 0.05, 306.39, 0.0),
}


def mu_over_slip(slip: float, c: tuple[float, float, float]) -> float:
    """μ(λ)/λ, with its limit at λ -> 0."""
    c1, c2, c3 = c
    if slip < 1e-6:
        return PSI * (c1 * c2 - c3)
    return PSI * (c1 * (1 - np.exp(-c2 * slip)) - c3 * slip) / slip


def derivatives(
    x: np.ndarray,
    delta: float,
    torque: float,
    d_x: float,
    c: tuple[float, float, float],
    printed: bool,
) -> np.ndarray:
    """ẋ of eqs. (2)-(16); d_x is the signed longitudinal acceleration for the loads."""
    v_x, v_y, r, w_f, w_r = x
    v_x = max(v_x, 0.1)
    n_wheels = 1.0 if printed else 2.0  # wheels per axle in the body equations
    drag = 0.5 * RHO * C_D * A_F * v_x**2 * H_A / (2 * L)
    if printed:  # eqs. (5)-(6) as printed
        f_zr = M * d_x * H / (2 * L) + W * L_R / (2 * L) - drag
        f_zf = -M * d_x * H / (2 * L) + W * L_F / (2 * L) + drag
    else:
        f_zf = W * L_R / (2 * L) - M * d_x * H / (2 * L) - drag
        f_zr = W * L_F / (2 * L) + M * d_x * H / (2 * L) + drag
    forces = []
    for w, lever, steer in ((w_f, L_F, delta), (w_r, -L_R, 0.0)):
        v_lat = v_y + lever * r
        v_w = np.hypot(v_lat, v_x)
        alpha = steer - np.arctan2(v_lat, v_x)
        s_x = (v_w - R_W * w * np.cos(alpha)) / v_w  # braking positive
        s_y = R_W * w * np.sin(alpha) / v_w
        s = np.hypot(s_x, s_y)
        forces.append((mu_over_slip(s, c) * s_x, mu_over_slip(s, c) * s_y))
    (kx_f, ky_f), (kx_r, ky_r) = forces
    f_xf, f_yf = kx_f * max(f_zf, 0.0), ky_f * max(f_zf, 0.0)
    f_xr, f_yr = kx_r * max(f_zr, 0.0), ky_r * max(f_zr, 0.0)
    cd, sd = np.cos(delta), np.sin(delta)
    dv_x = n_wheels * (-f_xf * cd - f_yf * sd - f_xr) / M + r * v_y
    dv_y = n_wheels * (f_yf * cd - f_xf * sd + f_yr) / M - r * v_x
    dr = n_wheels * (L_F * (f_yf * cd - f_xf * sd) - L_R * f_yr) / I_Z
    share = 1.0 / n_wheels  # each wheel of the axle takes its half of the axle's torque
    dw_f = (R_W * f_xf - K_B * torque * share) / I_W
    dw_r = (R_W * f_xr - (1 - K_B) * torque * share) / I_W
    return np.array([dv_x, dv_y, dr, dw_f, dw_r])


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
    """Wheel speed as the paper's DAQ recovers it from a 48-tooth sensor (note §4.1).

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
    printed = p["printed"] >= 0.5
    profile = int(p["profile"])
    v0 = p["v0_kmh"] / 3.6
    x = np.array([v0, 0.0, 0.0, v0 / R_W, v0 / R_W])
    fine = np.empty((n_fine, 5))
    abs_state = [1.0, 0.0]
    d_x = 0.0
    for k in range(n_fine):
        t_k = k * dt
        delta = p["steer_deg"] * np.pi / 180 * np.sin(2 * np.pi * p["steer_hz"] * t_k)
        # One ABS channel on the worse wheel: neither may lock.
        slip = (x[0] - R_W * min(x[3], x[4])) / max(x[0], 0.1)
        tq = _torque(profile, t_k, p["t_brake"], p["torque"], abs_state, slip, dt)
        fine[k] = x
        if x[0] < 0.3:  # stopped: the wheels and the body hold still
            x = np.array([x[0], 0.0, 0.0, x[0] / R_W, x[0] / R_W])
            continue
        k1 = derivatives(x, delta, tq, d_x, c, printed)
        k2 = derivatives(x + dt * k1, delta, tq, d_x, c, printed)
        d_x = k1[0]
        x = x + dt / 2 * (k1 + k2)
        x[3:] = np.maximum(x[3:], 0.0)  # a braked wheel stops, it does not turn back
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
        title="Braking car, single-track model with Burckhardt tires (seed 000, Pride)",
        params=(
            Param("v0_kmh", "km/h", default=90.0, lo=5.0, hi=180.0, doc="speed at brake onset"),
            Param(
                "surface",
                "1",
                default=0,
                lo=0,
                hi=6,
                doc="0 dry asphalt, 1 wet asphalt, "
                "2 dry concrete, 3 dry cobblestone, 4 wet cobblestone, 5 snow, 6 ice",
            ),
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
