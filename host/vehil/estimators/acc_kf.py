"""ACC reference-speed Kalman filter (seed 004, CN101655504A) and its calibration.

State x = [v_r, a_0] (speed, accelerometer bias), the raw acceleration a_m as the
input, the mean of the two non-driven wheel speeds as the measurement (the patent's eqs. 1-3):
    v_r(k+1) = v_r(k) + T (a_m(k) - a_0(k)),   a_0(k+1) = a_0(k) (+ w)
    v_m(k)   = r_w (w_l + w_r) / 2
Correction 1 (eq. 6): the bias process noise has the mean r̄ (a_f(k) - a_f(k-1)),
a_f the low-pass filtered acceleration (eqs. 4a/4b leave the filter open: a 2nd-order
Butterworth is our choice).
Correction 2 (eqs. 7-8): while braking C = [1 - s(k-1), 0], s = 1 - v_m / v̂_r from the
previous step. Guards the patent lacks (ours): s = 0 below `v_guard`,
s clamped to [0, s_max]; P kept symmetric.

The parameters are physical, so a scenario changes T (its sample_time) or the car in one
line: the process noise as densities (Q = diag(n_v, n_b) T, white noise on the speed and
a random walk of the bias), the low-pass as its cutoff (a Butterworth by the bilinear
transform with prewarping; 0 passes a_m, the patent's high-SNR case). The per-step
numbers are derived from them and T at CONFIG (`per_step`), on the board as here.

The float64 reference here is the same step the board runs (firmware/lib/estimators/
acc_kf.c), in double precision; `corr1`/`corr2` switch the corrections: the basic filter,
either correction alone, or both.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from vehil.estimators import register
from vehil.estimators._accel_conditioning import butter2
from vehil.estimators._health import MeanInnovation, outside_3sigma
from vehil.estimators.base import EstimatorSpec, Param, Signal

# The low-pass's cutoff may reach 0.4 of the sample rate (0.8 of Nyquist): beyond it the
# prewarped design has no margin left and the filter does not smooth anything.
LPF_MAX_FC_T = 0.4

PARAMS = (
    Param("T", "s", q=30, default=0.01, lo=1e-4, hi=0.1, doc="sample time"),
    Param("r_w", "m", q=24, default=0.30, lo=0.1, hi=1.0, doc="non-driven wheel radius"),
    Param(
        "n_v",
        "(m/s)^2/s",
        q=27,
        default=1e-3,
        lo=0.0,
        hi=10.0,
        doc="speed process-noise density: Q11 = n_v T (1e-5 at 10 ms; not in the patent)",
    ),
    Param(
        "n_b",
        "(m/s^2)^2/s",
        q=30,
        default=1e-4,
        lo=0.0,
        hi=1.0,
        doc="bias random-walk density: Q22 = n_b T (1e-6 at 10 ms; not in the patent)",
    ),
    Param("R", "(m/s)^2", q=24, default=0.05, lo=1e-6, hi=100.0, doc="measurement noise"),
    Param("p0_v", "(m/s)^2", q=24, default=1.0, lo=0.0, hi=7.9, doc="P(0) speed"),
    Param("p0_b", "(m/s^2)^2", q=30, default=0.1, lo=0.0, hi=1.0, doc="P(0) bias"),
    Param("rbar", "1", q=30, default=0.0284, lo=-1.0, hi=1.0, doc="r̄, eq. 5 (acc-calibrate)"),
    Param("corr1", "1", q=0, default=1.0, lo=0.0, hi=1.0, doc="correction 1 on (1) / off (0)"),
    Param("corr2", "1", q=0, default=1.0, lo=0.0, hi=1.0, doc="correction 2 on (1) / off (0)"),
    Param("v_guard", "m/s", q=16, default=0.5, lo=0.0, hi=10.0, doc="no slip below this speed"),
    Param(
        "lpf_hz",
        "Hz",
        q=24,
        default=2.0,
        lo=0.0,
        hi=100.0,
        doc="low-pass cutoff of a_f, at most 0.4/T; 0: a_f = a_m",
    ),
    Param(
        "z2_max",
        "1",
        q=16,
        default=50.0,
        lo=0.1,
        hi=1000.0,
        doc="the innovation's windowed mean, squared over its white-noise variance (χ²(1) "
        "when healthy), above which DIVERGED",
    ),
    Param("z_window", "s", q=24, default=1.0, lo=0.1, hi=100.0, doc="that mean's time"),
    Param("v_max", "m/s", q=16, default=100.0, lo=1.0, hi=200.0, doc="highest plausible speed"),
    Param(
        "s_max",
        "1",
        q=30,
        default=0.9,
        lo=0.0,
        hi=0.99,
        doc="slip ceiling: above it the wheels are taken as locked, carrying no speed",
    ),
)


@dataclass(frozen=True)
class PerStep:
    """Q11, Q22 and the LPF as the patent's (4b): a_f = Σ b_i a_m(k-i) + Σ c_j a_f(k-j)."""

    q_v: float
    q_b: float
    b: tuple[float, float, float]
    c: tuple[float, float]


def lpf_below_limit(p: Mapping[str, float], mode: str = "F32") -> str | None:
    """lpf_hz T <= 0.4: the low-pass's cutoff within reach of the sample time."""
    T, fc = p["T"], p["lpf_hz"]
    if fc * T > LPF_MAX_FC_T:
        return (
            f"lpf_hz = {fc:g} Hz is above {LPF_MAX_FC_T:g}/T = {LPF_MAX_FC_T / T:g} Hz "
            "at this sample time: lower it, or 0 to pass a_m unfiltered"
        )
    return None


def per_step(p: Mapping[str, float]) -> PerStep:
    """The step's numbers from the physical parameters and T, as CONFIG derives them."""
    T, fc = p["T"], p["lpf_hz"]
    if problem := lpf_below_limit(p):
        raise ValueError(f"acc_kf: {problem}")
    if fc > 0.0:
        lp = butter2(fc, T, highpass=False)
        b, c = (lp.b0, lp.b1, lp.b2), (-lp.a1, -lp.a2)
    else:
        b, c = (1.0, 0.0, 0.0), (0.0, 0.0)
    return PerStep(p["n_v"] * T, p["n_b"] * T, b, c)


@dataclass
class AccKF:
    """The patent's on-line filter (eqs. 1-8), float64. step(u) with u = [a_m, w_l, w_r, brake]."""

    p: Mapping[str, float]

    def __post_init__(self) -> None:
        self.k = per_step(self.p)
        self.started = False
        self.v = self.a0 = 0.0
        self.P = np.diag([self.p["p0_v"], self.p["p0_b"]])
        self.u_prev = 0.0
        self.w2_prev = 0.0  # ŵ_s(k-1), bias channel
        self.slip = 0.0
        self.health = MeanInnovation(self.p["T"], self.p["z_window"])
        self.diverged: list[bool] = []
        self.am_hist = [0.0, 0.0]  # a_m(k-1), a_m(k-2)
        self.af_hist = [0.0, 0.0]  # a_f(k-1), a_f(k-2)

    def _lpf(self, a_m: float) -> float:
        b, c = self.k.b, self.k.c
        a_f = (
            b[0] * a_m
            + b[1] * self.am_hist[0]
            + b[2] * self.am_hist[1]
            + c[0] * self.af_hist[0]
            + c[1] * self.af_hist[1]
        )
        self.am_hist = [a_m, self.am_hist[0]]
        self.af_hist = [a_f, self.af_hist[0]]
        return a_f

    def step(self, u: np.ndarray) -> np.ndarray:
        a_m, w_l, w_r, brake = (float(x) for x in u)
        p = self.p
        T = p["T"]
        v_m = p["r_w"] * (w_l + w_r) / 2
        braking = brake > 0.5
        if not self.started:
            # x̂(0) = [v_m(0), 0]; the LPF starts in steady state at a_m(0) (the patent gives no
            # initial state; from rest its start-up would enter â_0 as r̄ (a_f(k) - a_f(0))).
            self.started = True
            self.v, self.a0 = v_m, 0.0
            self.u_prev = a_m
            self.am_hist = [a_m, a_m]
            self.af_hist = [a_m, a_m]
            self.diverged.append(False)
            return np.array([self.v, self.a0])
        # Prediction with the previous input and noise mean, as the patent orders it.
        w2 = self.w2_prev if p["corr1"] >= 0.5 else 0.0
        v_pred = self.v + T * (self.u_prev - self.a0)
        b_pred = self.a0 + w2
        P = self.P
        m11 = P[0, 0] - 2 * T * P[0, 1] + T * T * P[1, 1] + self.k.q_v
        m12 = P[0, 1] - T * P[1, 1]
        m22 = P[1, 1] + self.k.q_b
        c = 1.0 - self.slip if (braking and p["corr2"] >= 0.5) else 1.0
        S = c * c * m11 + p["R"]
        k1, k2 = c * m11 / S, c * m12 / S
        e = v_m - c * v_pred
        self.v = v_pred + k1 * e
        self.a0 = b_pred + k2 * e
        # P = (I - K C) M, kept symmetric.
        self.P = np.array(
            [[m11 - k1 * c * m11, m12 - k1 * c * m12], [m12 - k1 * c * m12, m22 - k2 * c * m12]]
        )
        # Health (docs/estimators/acc_kf.md): the innovation's windowed mean against its
        # white-noise spread, and v̂ within 3σ of [-v_guard, v_max] (near standstill the
        # filter is not held to its speed).
        z2 = self.health.update(e, S)
        off = outside_3sigma(self.v, -p["v_guard"], p["v_max"], self.P[0, 0])
        self.diverged.append(z2 > p["z2_max"] or off)
        a_f = self._lpf(a_m)
        self.w2_prev = p["rbar"] * (a_f - self.af_hist[1])
        if braking and self.v > p["v_guard"]:
            self.slip = min(max(1.0 - v_m / self.v, 0.0), p["s_max"])
        else:
            self.slip = 0.0
        self.u_prev = a_m
        return np.array([self.v, self.a0])


def run(params: Mapping[str, float], inputs: np.ndarray) -> np.ndarray:
    kf = AccKF(params)
    return np.array([kf.step(u) for u in inputs])


# -- offline calibration of r̄ (the patent's eq. 5 and Fig. 3) ---------------------


@dataclass(frozen=True)
class Segment:
    """One change of a_f from a steady level to another (the patent's Fig. 3)."""

    start: int  # S
    end: int  # E1
    settled: int  # E2: the bias estimate is steady again
    a_before: float  # ā_1
    a_after: float  # ā_2
    bias_before: float  # ā_{0,1}
    bias_after: float  # ā_{0,2}

    @property
    def r(self) -> float:
        return (self.bias_after - self.bias_before) / (self.a_after - self.a_before)


@dataclass(frozen=True)
class Calibration:
    rbar: float
    segments: tuple[Segment, ...]


def _steady(x: np.ndarray, window: int, tol: float) -> np.ndarray:
    """True where x stays within ±tol of its value over the next `window` samples."""
    from numpy.lib.stride_tricks import sliding_window_view

    if len(x) < window:
        return np.zeros(len(x), dtype=bool)
    w = sliding_window_view(x, window)
    ok = (w.max(axis=1) - w.min(axis=1)) <= 2 * tol
    return np.concatenate([ok, np.zeros(window - 1, dtype=bool)])


def calibrate_rbar(
    runs: Sequence[np.ndarray],
    params: Mapping[str, float] | None = None,
    *,
    window_s: float = 1.5,
    a_tol: float = 0.08,
    bias_tol: float = 0.004,
    min_step: float = 0.5,
) -> Calibration:
    """r̄ from straight-line runs: each an (N, 4) array of [a_m, w_l, w_r, brake].

    Runs the basic KF and the LPF, finds every change of a_f between two steady
    levels at least `min_step` apart, takes the bias estimate's change across it
    at the end of the new level (windows t1, t2, t3 of `window_s`), and averages
    r_i = Δâ_0 / Δa_f over all segments (eq. 5)."""
    p = dict(spec_defaults() if params is None else params)
    p.update(corr1=0.0, corr2=0.0)
    n_win = max(3, int(round(window_s / p["T"])))
    segments = []
    for inputs in runs:
        est = run(p, inputs)
        lpf = AccKF(p)
        lpf.am_hist = [inputs[0, 0]] * 2
        lpf.af_hist = [inputs[0, 0]] * 2
        a_f = np.array([lpf._lpf(a) for a in inputs[:, 0]])
        bias = est[:, 1]
        steady_a = _steady(a_f, n_win, a_tol)
        steady_b = _steady(bias, n_win, bias_tol)
        k = 0
        while k < len(a_f):
            # t1: a steady window of a_f ending at S, then a_f leaves it.
            if not steady_a[k]:
                k += 1
                continue
            start = k + n_win
            while start < len(a_f) and steady_a[start - n_win + 1]:
                start += 1
            level = float(np.mean(a_f[start - n_win : start]))
            # E1: the next steady window at a different level.
            end = start
            while end < len(a_f) and not (
                steady_a[end] and abs(np.mean(a_f[end : end + n_win]) - level) >= min_step
            ):
                end += 1
            if end >= len(a_f):
                break
            # t3: the bias estimate keeps converging while a_f holds its new level, so
            # take it at the end of that level (E2), just before a_f moves again.
            new_level = float(np.mean(a_f[end : end + n_win]))
            leave = end + n_win
            while leave < len(a_f) and abs(a_f[leave] - new_level) <= 2 * a_tol:
                leave += 1
            settled = leave - n_win
            if settled <= end or not steady_b[settled]:
                k = end
                continue
            segments.append(
                Segment(
                    start=start,
                    end=end,
                    settled=settled,
                    a_before=level,
                    a_after=new_level,
                    bias_before=float(np.mean(bias[start - n_win : start])),
                    bias_after=float(np.mean(bias[settled : settled + n_win])),
                )
            )
            k = end
    if not segments:
        raise ValueError(
            "no segment where the acceleration moves between two steady levels: "
            "record straight runs with sustained acceleration and deceleration phases"
        )
    return Calibration(float(np.mean([s.r for s in segments])), tuple(segments))


def spec_defaults() -> dict[str, float]:
    return {p.name: p.default for p in PARAMS}


SPEC = register(
    EstimatorSpec(
        name="acc_kf",
        budget={"FIXED": 4_000},
        budget_scenario="mixed",  # both corrections
        c_id=10,
        title="ACC reference speed: Kalman filter with bias feed-forward and slip correction",
        inputs=(
            Signal("a_m", "m/s^2", q=24, doc="measured longitudinal acceleration"),
            Signal("omega_l", "rad/s", q=16, doc="left non-driven wheel speed"),
            Signal("omega_r", "rad/s", q=16, doc="right non-driven wheel speed"),
            Signal("brake", "1", q=0, doc="brake switch: 1 braking, 0 not"),
        ),
        outputs=(
            Signal("v", "m/s", q=16, doc="reference speed v̂_r"),
            Signal("a0", "m/s^2", q=24, doc="accelerometer bias â_0"),
        ),
        reference=AccKF,
        params=PARAMS,
        rules=(lpf_below_limit,),
        paper="004-acc-speed-kalman-patent",
    )
)
