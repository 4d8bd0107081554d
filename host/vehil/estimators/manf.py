"""MANF and the original ANF: vehicle speed during braking from wheel speed alone (seed 000).

MANF (the paper's Sec. 3.2, eqs. 39-44) tracks the wheel's circumferential speed R ω with a
rate-limited tanh law and an adaptive gain R_g: ×γ while the error keeps its sign, ×ξ when
it flips, R_g in [0, a], |v̂(k) - v̂(k-1)| <= a T. Beyond the paper, by default: γ and ξ
are rates per t_ref = 1 ms of time (the same filter at any sample time), and an error
within ±e_db (the wheel speed's noise) carries no sign, so noise neither grows nor
shrinks R_g (docs/estimators/manf.md, "Sample time and noise"). The printed update
(eq. 44) has the wrong feedback sign and leaves out T; by default this builds the
corrected law (reading B: v̂ -= T R_g tanh(v̂ - R ω)), with switches for the printed sign,
the literal reading A (no T: R_g in m/s per step) and the wheel used (front, rear, or the
faster of the two). The ANF of [3] (eq. 38: sgn and a fixed gain) is the baseline.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from vehil.estimators import register
from vehil.estimators.base import EstimatorSpec, Param, Signal, t_ref_param

R_W = 0.27  # Table 2

# What both seed-000 estimators take: the two wheel speeds and nothing else.
WHEEL_SPEEDS = (
    Signal("omega_f", "rad/s", q=16, doc="front wheel speed"),
    Signal("omega_r", "rad/s", q=16, doc="rear wheel speed"),
)


def _wheel_speed(p: Mapping[str, float], u: np.ndarray) -> float:
    w_f, w_r = float(u[0]), float(u[1])
    wheel = int(p["wheel"])
    w = w_f if wheel == 0 else w_r if wheel == 1 else max(w_f, w_r)
    return p["r_w"] * w


GAMMA_MAX = 1.9  # R_g γ must stay below 2^32 in FIXED's unsigned Q24 (docs/estimators/manf.md)


def per_sample_rates(p: Mapping[str, float]) -> tuple[float, float]:
    """γ and ξ as the step applies them. With t_ref = 0 (the paper) they act per sample;
    with t_ref > 0 they are rates per t_ref of time (beyond the paper), so a step of T
    applies γ^(T / t_ref) and ξ^(T / t_ref) and the filter is the same at any sample time."""
    if p["t_ref"] <= 0.0:
        return p["gamma"], p["xi"]
    k = p["T"] / p["t_ref"]
    return p["gamma"] ** k, p["xi"] ** k


def gamma_within_range(p: Mapping[str, float], mode: str = "F32") -> str | None:
    """The per-sample γ at most GAMMA_MAX (a rate per t_ref raised to T / t_ref can pass it)."""
    gamma, _ = per_sample_rates(p)
    if gamma > GAMMA_MAX:
        return (
            f"gamma^(T / t_ref) = {gamma:.4g} is above {GAMMA_MAX:g} per sample: "
            "lower gamma, shorten T or lengthen t_ref"
        )
    return None


class Manf:
    """MANF as docs/estimators/manf.md reads it, float64. step([ω_f, ω_r]) -> [v̂, R_g]."""

    def __init__(self, p: Mapping[str, float]):
        if problem := gamma_within_range(p):
            raise ValueError(f"manf: {problem}")
        self.p = p
        self.gamma, self.xi = per_sample_rates(p)
        self.v: float | None = None
        self.rg = p["rg0"]
        self.s_prev = 0

    def step(self, u: np.ndarray) -> np.ndarray:
        p = self.p
        v_w = _wheel_speed(p, u)
        if self.v is None:
            self.v = v_w  # v̂(0) = R ω(0)
            return np.array([self.v, self.rg])
        e = self.v - v_w  # the a-priori error, for the law and the adaptation (manf.md)
        s = int(np.sign(e)) if abs(e) > p["e_db"] else 0  # within the band: no sign
        if self.s_prev != 0 and s != 0:
            self.rg *= self.gamma if s == self.s_prev else self.xi
        self.rg = min(max(self.rg, 0.0), p["a"])
        step = self.rg * np.tanh(e)
        if p["reading"] < 0.5:  # reading B: R_g is an acceleration
            step *= p["T"]
        dv = step if p["printed_sign"] >= 0.5 else -step
        limit = p["a"] * p["T"]
        self.v += min(max(dv, -limit), limit)
        if s != 0:
            self.s_prev = s
        return np.array([self.v, self.rg])


class Anf:
    """The original ANF, eq. 38 with the working sign and reading B: v̂ -= T R_g sgn(v̂ - R ω),
    R_g fixed. step([ω_f, ω_r]) -> [v̂]."""

    def __init__(self, p: Mapping[str, float]):
        self.p = p
        self.v: float | None = None

    def step(self, u: np.ndarray) -> np.ndarray:
        v_w = _wheel_speed(self.p, u)
        if self.v is None:
            self.v = v_w
        else:
            self.v -= self.p["rg"] * self.p["T"] * np.sign(self.v - v_w)
        return np.array([self.v])


COMMON = (
    Param("T", "s", q=30, default=0.001, lo=1e-4, hi=0.1, doc="sample time"),
    Param("r_w", "m", q=24, default=R_W, lo=0.1, hi=1.0, doc="wheel radius"),
    Param("wheel", "1", q=0, default=0, lo=0, hi=2, doc="0 front, 1 rear, 2 the faster"),
)

SPEC = register(
    EstimatorSpec(
        name="manf",
        budget={"FIXED": 800, "F32": 2_000},
        c_id=20,
        title="MANF: modified adaptive nonlinear filter (seed 000)",
        inputs=WHEEL_SPEEDS,
        outputs=(
            Signal("v", "m/s", q=16, doc="vehicle speed v̂_x"),
            Signal("rg", "m/s^2", q=24, doc="adaptive gain R_g"),
        ),
        reference=Manf,
        params=(
            *COMMON,
            Param("gamma", "1", q=30, default=1.01, lo=1.0, hi=1.9, doc="gain growth, eq. 39"),
            Param("xi", "1", q=30, default=0.99, lo=0.0, hi=1.0, doc="gain decay, eq. 40"),
            Param("rg0", "m/s^2", q=24, default=1.0, lo=0.0, hi=100.0, doc="R_g(0)"),
            Param("a", "m/s^2", q=24, default=8.0, lo=0.1, hi=100.0, doc="tolerable accel"),
            Param("printed_sign", "1", q=0, default=0, lo=0, hi=1, doc="1: eq. 44's sign"),
            Param("reading", "1", q=0, default=0, lo=0, hi=1, doc="0: T R_g (B), 1: R_g (A)"),
            t_ref_param(
                "0: γ, ξ per sample (the paper); > 0: per t_ref, as γ^(T/t_ref), ξ^(T/t_ref)",
                default=0.001,
            ),
            Param(
                "e_db",
                "m/s",
                q=24,
                default=0.2,
                lo=0.0,
                hi=10.0,
                doc="errors within ±e_db carry no sign for eqs. 39-40 (~3 r_w σ_ω); 0: the paper",
            ),
        ),
        rules=(gamma_within_range,),
        paper="000-manf-uiiekf-braking",
    )
)

ANF = register(
    EstimatorSpec(
        name="anf",
        budget={"FIXED": 800, "F32": 1_000},
        c_id=22,
        title="ANF: the adaptive nonlinear filter MANF modifies, fixed gain (seed 000)",
        inputs=WHEEL_SPEEDS,
        outputs=(Signal("v", "m/s", q=16, doc="vehicle speed v̂_x"),),
        reference=Anf,
        params=(
            *COMMON,
            Param("rg", "m/s^2", q=24, default=8.0, lo=0.0, hi=100.0, doc="fixed gain R_g"),
        ),
        paper="000-manf-uiiekf-braking",
    )
)
