"""A front-engined sedan driving straight, as seed 002's STLQF/RLS estimators see it.

The paper's model (its Section 2): engine (eq. 1) with a throttle/speed torque map, torque
converter (eq. 2, T_i = (ω_e / K_f)², T_t = C_tr T_i), 5-speed automatic with a shift
schedule, brake T_b = K_b P_b acting against motion (eq. 5 prints "+ T_b"), aero, rolling
and grade resistance (eqs. 5-10), Table 1 parameters; v and ω_e integrated with two-step
Adams-Bashforth (eq. 30) at the sample time. The estimators get v, v̇ (exact, as the paper
uses them, or with sensor noise) and z = F_x + σ_N N(0, 1) (eq. 27).

The paper omits the engine map, the converter tables and the shift schedule; the
substitutes here (scaled to 75 kW / 155 N·m, each number's origin beside it) are:
- full-load torque: a petrol curve through 155 N·m at 4200 rpm and 75 kW at
  6000 rpm (119 N·m); closed-throttle drag -(8 + 0.0045 rpm) N·m; part throttle
  T_e = g T_full + (1 - g) T_drag with g = 1 - (1 - α)² (the progressive pedal of
  `sldemo_autotrans`'s map: half the torque at ~30 % throttle); an idle governor
  holds ~800 rpm and a limiter cuts fuel above 6500 rpm;
- converter: the shape of `sldemo_autotrans`'s K-factor and torque-ratio tables
  (2.23 falling to 1.0 at coupling, K rising steeply past 0.8), K scaled by
  √(453/155) for the smaller engine and to SI, so stall is at ~2400 rpm; past the
  last breakpoint (0.94) the torque fades linearly to 0 at speed ratio 1 and turns
  into engine braking above it;
- shifts at 2000 rpm at closed throttle up to ~5800 rpm at full throttle
  (linear in between), downshifts at 70 % of the upshift speed.

Grade (`road`): 0 the GPS road of the paper's Section 4-1, rebuilt: a ~1.3 km hilly street
with steep local grades (altitude vs distance), driven once from rest by a "GPS car"
logged at 1 s (speed, altitude, with GPS noise and dropped fixes), then processed as the
paper does: missing fixes interpolated, speed smoothed by eq. 28 (k = 4), distance
integrated, grade by eq. 29, and the grade against *time* applied to the simulated car,
resampled to the sample time linearly (`resample` = 0; its kinks every second make STLQF's
outliers: windows that straddle one) or by a cubic spline (1; the paper does not say how
it resampled); `gps = "file.csv"` in a scenario's [plant] puts a real GPS log (columns t
[s], speed [m/s], altitude [m]) through the same pipeline instead; 1 flat; 2 a smooth
grade 5° sin(0.3 t), ours (`grade_deg` and `grade_rad_s` change its amplitude and
frequency, for drives unlike the paper's).

Drives (`profile`): 0 the paper's 75 s from rest (a throttle trace like Fig. 16's); 1
strong throttle steps on a flat road; 2 a constant throttle, `cruise_throttle` (the car
settles to a cruise: ψ barely moves, nothing excites RLS); `dither` adds a small fast
throttle dither (sign flips every 20-40 ms): on a smooth throttle the STLQF window system
is nearly singular, the dither conditions it (docs/estimators/stlqf.md). `mass` and `cda`
replace Table 1's 1250 kg and 0.48 m² (a heavier or draggier car than the shipped drives);
`mass_step` kg is added at `t_mass` (a trailer or passengers); `noise` = 1 gives realistic
sensors (σ 0.05 m/s on v, 0.1 m/s² on v̇, 10 N on z) instead of the paper's σ_N on z
alone, each times `noise_scale`; `v_dot_bias` and `z_bias` offset those sensors, and
`f_roll` replaces Table 1's rolling resistance coefficient 0.015 (the estimators assume it
through ε)."""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterator, Mapping
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from vehil.plants import register
from vehil.plants.base import FileInput, NoiseBlocks, PlantSpec, Trace, chunk_times, joined
from vehil.spec import Param, Signal

# Table 1; ρ and g as the paper's Section 2 gives them.
M, R_W, R_FD, K_B, I_EI, CDA, F_ROLL = 1250.0, 0.298, 4.1, 540.0, 0.16, 0.48, 0.015
GEARS = (3.78, 2.12, 1.36, 1.03, 0.84)
RHO, G = 1.206, 9.81

RPM = np.pi / 30.0  # rad/s per rpm
_FULL_RPM = np.array([800, 1500, 2500, 3500, 4200, 5000, 6000, 6500], float)
_FULL_NM = np.array([95, 120, 142, 152, 155, 148, 119, 100], float)
IDLE_RPM, LIMIT_RPM = 800.0, 6500.0

_SR = np.array([0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.94])
_K = np.array([21.0, 21.0, 21.1, 21.3, 21.6, 22.1, 22.9, 24.3, 27.0, 29.5, 33.5, 37.6])
_CTR = np.array([2.23, 2.05, 1.9, 1.75, 1.6, 1.45, 1.3, 1.17, 1.05, 1.0, 1.0, 1.0])

UPSHIFT_RPM = (2000.0, 5800.0)  # at closed and at full throttle
DOWNSHIFT_FRACTION = 0.7


def engine_torque(throttle: float, w_e: float) -> float:
    rpm = w_e / RPM
    if rpm > LIMIT_RPM:
        throttle = 0.0
    # Idle governor: opens the throttle as the engine falls below idle.
    throttle = max(throttle, min(0.3, 0.03 + (IDLE_RPM - rpm) / IDLE_RPM))
    g = 1.0 - (1.0 - throttle) ** 2
    full = float(np.interp(rpm, _FULL_RPM, _FULL_NM))
    drag = -(8.0 + 0.0045 * rpm)
    return g * full + (1.0 - g) * drag


def converter(w_e: float, w_in: float) -> tuple[float, float]:
    """(pump torque T_i, turbine torque T_t) for engine and gearbox-input speeds."""
    sr = w_in / max(w_e, 1.0)
    if sr <= _SR[-1]:
        k, ctr = float(np.interp(sr, _SR, _K)), float(np.interp(sr, _SR, _CTR))
        t_i = (w_e / k) ** 2
        return t_i, ctr * t_i
    # Past the table: torque fades to 0 at coupling, then the car drives the engine.
    t_i = (max(w_e, w_in) / _K[-1]) ** 2 * (1.0 - sr) / (1.0 - _SR[-1])
    return t_i, t_i


def shift(gear: int, v: float, throttle: float) -> int:
    """The next gear (0-based) from the output shaft speed and the throttle."""
    up_rpm = UPSHIFT_RPM[0] + throttle * (UPSHIFT_RPM[1] - UPSHIFT_RPM[0])
    w_out = R_FD * v / R_W
    if gear + 1 < len(GEARS) and w_out * GEARS[gear] > up_rpm * RPM:
        return gear + 1
    if gear > 0 and w_out * GEARS[gear - 1] < DOWNSHIFT_FRACTION * up_rpm * RPM:
        return gear - 1
    return gear


def altitude(x: np.ndarray) -> np.ndarray:
    """The hilly street: altitude (m) against distance (m); steepest near the start."""
    return (
        6.0 * np.sin(2 * np.pi * x / 650.0)
        + 1.5 * np.sin(2 * np.pi * x / 170.0 + 1.0)
        + 0.3 * np.sin(2 * np.pi * x / 55.0 + 2.0)
        + 3.0 * np.exp(-(((x - 120.0) / 40.0) ** 2))
    )


def gps_log(duration: float, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """A simulated 1 s GPS log of a drive along the street, for the paper's Section 4-1 pipeline."""
    t_gps = np.arange(0.0, duration + 2.0, 1.0)
    # The GPS car: from rest to ~70 km/h, easing off over the crests: ~1.3 km in 75 s.
    v_true = 19.5 * (1 - np.exp(-t_gps / 9.0)) * (1 + 0.12 * np.sin(2 * np.pi * t_gps / 31.0))
    x_true = np.concatenate([[0.0], np.cumsum((v_true[1:] + v_true[:-1]) / 2)])
    speed = np.maximum(v_true + rng.normal(0.0, 0.3, len(t_gps)), 0.0)
    alt = altitude(x_true) + 1200.0 + rng.normal(0.0, 0.15, len(t_gps))
    lost = rng.random(len(t_gps)) < 0.05  # dropped fixes, linearly interpolated
    lost[[0, -1]] = False
    speed = np.interp(t_gps, t_gps[~lost], speed[~lost])
    alt = np.interp(t_gps, t_gps[~lost], alt[~lost])
    return {"t": t_gps, "speed": speed, "altitude": alt, "distance": x_true}


def process_gps(
    t: np.ndarray, speed: np.ndarray, alt: np.ndarray, t_out: np.ndarray, smooth: bool
) -> np.ndarray:
    """Grade (deg) at t_out from a GPS log: eq. 28 on the speed, distance, eq. 29, then
    resampled linearly (kinks every second) or by a cubic spline (smooth)."""
    return gps_grade(t, speed, alt, smooth)(t_out)


def gps_grade(
    t: np.ndarray, speed: np.ndarray, alt: np.ndarray, smooth: bool
) -> Callable[[np.ndarray], np.ndarray]:
    """process_gps's grade (deg) as a function of time, for a drive made in chunks."""
    k = 4
    v_avg = np.convolve(speed, np.ones(k) / k)[: len(speed)]
    v_avg[: k - 1] = np.cumsum(speed[: k - 1]) / np.arange(1, k)
    x = np.concatenate([[0.0], np.cumsum(v_avg[:-1] * np.diff(t))])
    dx, dh = np.diff(x), np.diff(alt)
    beta = np.degrees(np.arctan2(dh, np.maximum(dx, 1e-9)))
    beta[dx < 0.5] = 0.0  # standing still: no grade from GPS noise
    beta = np.append(beta, beta[-1])
    if smooth:
        return CubicSpline(t, beta)
    return lambda t_out: np.interp(t_out, t, beta)


def throttle_trace(profile: int, t: np.ndarray, cruise: float) -> np.ndarray:
    if profile == 0:  # Fig. 16-like: pull away, cruise with lifts and re-accelerations
        knots = (
            [0, 2, 8, 15, 22, 28, 35, 40, 46, 52, 60, 66, 75],
            [0.3, 0.35, 0.3, 0.2, 0.18, 0.25, 0.15, 0.05, 0.22, 0.2, 0.28, 0.15, 0.18],
        )
        return np.interp(t, *knots)
    if profile == 1:  # strong steps between light and heavy throttle every 4 s
        return np.where((t // 4.0) % 2 == 0, 0.7, 0.05)
    return np.full_like(t, cruise)  # 2: a constant throttle, the car settles to a cruise


class Dither:
    """±amplitude with sign flips every 20-40 ms, `take(m)` samples at a time."""

    def __init__(self, T: float, amplitude: float, rng: np.random.Generator):
        self.T, self.amplitude, self.rng = T, amplitude, rng
        self.sign, self.left = -1.0, 0  # the current hold's sign and samples still to go

    def take(self, m: int) -> np.ndarray:
        out = np.empty(m)
        k = 0
        while k < m:
            if self.left == 0:  # a new hold, of the other sign (the first is +)
                self.sign = -self.sign
                self.left = max(1, int(round(self.rng.uniform(0.02, 0.04) / self.T)))
            step = min(self.left, m - k)
            out[k : k + step] = self.sign * self.amplitude
            k, self.left = k + step, self.left - step
        return out

    def skip(self, n: int) -> None:
        """Draws the next n samples' holds, a chunk at a time, keeping none of them."""
        for k0 in range(0, n, 1 << 16):
            self.take(min(1 << 16, n - k0))


def _grade(
    p: Mapping[str, Any], duration: float, rng: np.random.Generator
) -> Callable[[np.ndarray], np.ndarray]:
    """The road's grade (rad) as a function of time."""
    gps = p.get("gps")
    road = int(p["road"])
    if gps is not None:
        f = gps_grade(gps["t"] - gps["t"][0], gps["speed"], gps["altitude"], p["resample"] >= 0.5)
        return lambda t: np.deg2rad(f(t))
    if road == 0:
        log = gps_log(duration, rng)
        f = gps_grade(log["t"], log["speed"], log["altitude"], p["resample"] >= 0.5)
        return lambda t: np.deg2rad(f(t))
    if road == 1:
        return np.zeros_like
    return lambda t: np.deg2rad(p["grade_deg"]) * np.sin(p["grade_rad_s"] * t)


def _stream(
    p: Mapping[str, Any], duration: float, T: float, seed: int, chunk: int
) -> Iterator[Trace]:
    rng = np.random.default_rng(seed)
    n = int(round(duration / T))
    grade_at = _grade(p, duration, rng)
    dither = Dither(T, p["dither"], copy.deepcopy(rng))
    Dither(T, p["dither"], rng).skip(n)  # the noise is drawn after the whole drive's dither
    noise = NoiseBlocks(rng, n, 3)  # v, v̇, z
    noisy = p["noise"] >= 0.5
    sd_v, sd_a, sd_z = (0.05, 0.1, 10.0) if noisy else (0.0, 0.0, p["sigma_n"])
    sd_v, sd_a, sd_z = (sd * p["noise_scale"] for sd in (sd_v, sd_a, sd_z))
    cda = p["cda"]
    v, w_e, gear = 0.0, IDLE_RPM * RPM, 0
    prev = None
    for t in chunk_times(n, T, chunk):
        m = len(t)
        grade = grade_at(t)
        trace = throttle_trace(int(p["profile"]), t, p["cruise_throttle"])
        throttle = np.clip(trace + dither.take(m), 0.0, 1.0)
        mass = np.where(t >= p["t_mass"], p["mass"] + p["mass_step"], p["mass"])
        p_brake = np.where((t >= p["t_brake"]) & (t < p["t_brake"] + 3.0), p["brake_mpa"], 0.0)
        throttle[p_brake > 0] = 0.0
        out = np.zeros((m, 5))  # v, v̇, F_x, gear, engine rpm
        for k in range(m):
            gear = shift(gear, v, float(throttle[k]))
            w_in = GEARS[gear] * R_FD * v / R_W
            t_i, t_t = converter(w_e, w_in)
            dw = (engine_torque(float(throttle[k]), w_e) - t_i) / I_EI
            t_b = K_B * p_brake[k] if v > 0 else 0.0
            f_x = (GEARS[gear] * R_FD * t_t - t_b) / R_W  # eq. 5, brake against motion
            resist = 0.5 * cda * RHO * v * v + mass[k] * G * (
                p["f_roll"] * np.cos(grade[k]) + np.sin(grade[k])
            )
            dv = (f_x - resist) / mass[k]
            if v <= 0.0 and dv < 0.0:  # at rest: the brake/static friction holds the car
                dv = 0.0
            out[k] = v, dv, f_x, gear + 1, w_e / RPM
            d = np.array([dv, dw])
            step = T * d if prev is None else T * (1.5 * d - 0.5 * prev)  # eq. 30
            prev = d
            v, w_e = max(v + step[0], 0.0), max(w_e + step[1], 1.0)
        yield Trace(
            t=t,
            signals={
                "v": out[:, 0] + noise.normal(0, sd_v, m) * (sd_v > 0),
                "v_dot": out[:, 1] + noise.normal(1, sd_a, m) * (sd_a > 0) + p["v_dot_bias"],
                "z": out[:, 2] + noise.normal(2, 1.0, m) * sd_z + p["z_bias"],
                "throttle": throttle,
                "gear": out[:, 3],
                "engine_rpm": out[:, 4],
            },
            truth={
                "m": mass,
                "cda": np.full(m, cda),
                "grade": np.degrees(grade),
                "v_true": out[:, 0],
            },
        )


SPEC = register(
    PlantSpec(
        name="longitudinal",
        title="Sedan, engine + torque converter + 5-speed automatic, straight road (seed 002)",
        params=(
            Param(
                "profile",
                "1",
                default=0,
                lo=0,
                hi=2,
                doc="0 paper-like 75 s, 1 throttle steps, 2 constant throttle (a cruise)",
            ),
            Param("cruise_throttle", "1", default=0.12, lo=0.0, hi=1.0, doc="profile 2's"),
            Param("road", "1", default=0, lo=0, hi=2, doc="0 GPS road, 1 flat, 2 5° sin(0.3 t)"),
            Param("resample", "1", default=0, lo=0, hi=1, doc="GPS grade: 0 linear, 1 spline"),
            Param("dither", "1", default=0.0, lo=0.0, hi=0.2, doc="throttle dither amplitude"),
            Param("mass", "kg", default=M, lo=500.0, hi=4000.0, doc="vehicle mass (Table 1)"),
            Param("cda", "m^2", default=CDA, lo=0.1, hi=3.0, doc="C_dA_f (Table 1)"),
            Param("grade_deg", "deg", default=5.0, lo=0.0, hi=15.0, doc="road 2's amplitude"),
            Param("grade_rad_s", "rad/s", default=0.3, lo=0.01, hi=3.0, doc="road 2's frequency"),
            Param("mass_step", "kg", default=0.0, lo=-300.0, hi=1500.0, doc="added at t_mass"),
            Param("t_mass", "s", default=1e9, lo=0.0, hi=1e9),
            Param("brake_mpa", "MPa", default=0.0, lo=0.0, hi=10.0, doc="brake pressure for 3 s"),
            Param("t_brake", "s", default=1e9, lo=0.0, hi=1e9),
            Param("sigma_n", "N", default=1e-4, lo=0.0, hi=1e3, doc="σ_N on z (eq. 27)"),
            Param("noise", "1", default=0, lo=0, hi=1, doc="1: realistic v, v̇, z sensors"),
            Param("noise_scale", "1", default=1.0, lo=0.0, hi=100.0, doc="× the sensors' σ"),
            Param("v_dot_bias", "m/s^2", default=0.0, lo=-2.0, hi=2.0, doc="v̇ sensor bias"),
            Param("z_bias", "N", default=0.0, lo=-500.0, hi=500.0, doc="z (F_x) sensor bias"),
            Param("f_roll", "1", default=F_ROLL, lo=0.0, hi=0.05, doc="rolling resistance coeff."),
        ),
        signals=(
            Signal("v", "m/s"),
            Signal("v_dot", "m/s^2"),
            Signal("z", "N"),
            Signal("throttle", "1"),
            Signal("gear", "1"),
            Signal("engine_rpm", "rpm"),
        ),
        truth=(
            Signal("m", "kg"),
            Signal("cda", "m^2"),
            Signal("grade", "deg"),
            Signal("v_true", "m/s"),
        ),
        simulate=joined(_stream),
        stream=_stream,
        files=(
            FileInput(
                "gps",
                (Signal("t", "s"), Signal("speed", "m/s"), Signal("altitude", "m")),
                "a GPS log whose grade replaces the road's (the paper's Section 4-1 pipeline)",
            ),
        ),
    )
)
