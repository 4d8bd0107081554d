"""Mass, drag area and road grade from v, v̇ and the tractive force (seed 002): STLQF and RLS.

Both fit eq. 24, m v̇ + C_dA_f ½ρv² + m sin(ε + β_r) g/cos ε = F_x, with
ψ = [v̇, ½ρv², g/cos ε] and θ = [m, C_dA_f, m sin(ε + β_r)]; grade β̂_r = asin(θ̂_3/θ̂_1) - ε
(the paper's eqs. 24-27, ε = atan f known).

STLQF (the paper's eqs. 11-23, eq. 16's misprinted β taken from eq. 14): each parameter is
linear in local time inside an 11-sample window (r = 1, WL = 5), the generalised error is
filtered with α = 1 + χ1/T + χ2/T², β = -(χ1/T + 2χ2/T²), γ = χ2/T², and the window cost
of eq. 23 with the weights A (Table 3) is minimised; the estimate is the linear model at the
window centre, WL samples (0.05 s) old. Two things differ from the paper, both because its
6×6 system is nearly singular on smooth drives (docs/estimators/stlqf.md):
- Eq. 23's G = Σ_k W_kᵀ A W_k is formed as Xᵀ X with X = R Φ̃, R the banded Cholesky
  factor of the 9×9 weight that A spreads over the window's nine filtered rows (so
  the weights cost nothing per step), and the filters are taken as differences
  (ψ + χ1 Δψ/T + χ2 Δ²ψ/T²), not as α ψ + β ψ₋₁ + γ ψ₋₂ with α ≈ 1e4, which cancels
  away float32's digits.
- The system is Jacobi-scaled (unit diagonal) and solved by Cholesky with a small
  Tikhonov term μ pulling each parameter's value towards the previous window's (moved
  on one sample) and its slope towards zero: where the window's data leave a
  direction undetermined the estimate holds instead of amplifying round-off. μ = 0 is
  the paper's unregularised solve. μ = 1e-2 by default: float32's rounding of the
  inputs, amplified ~1e4 by the error filter, needs it (float64 does well with 1e-4).
  Each step reports log10 of the solved matrix's condition estimate, and
  ILL_CONDITIONED when the window's data do not determine the mass: the prior's share
  of m̂ (μ [(G_s + μ I)⁻¹]_mm, 0 when the data alone fix it, 1 when the prior does)
  exceeds `held_max`. A condition number cannot say this: μ bounds the regularised
  system's near 1/μ whatever the data, and the unregularised one is 1e8 on good drives.

The float64 reference below is the same step as the board's C (firmware/lib/
estimators/stlqf.c); `exact_cond` keeps numpy's condition number of the scaled,
unregularised G per window for the report.

RLS (the paper's baseline, after its ref. [14]): λ = 0.95 on the same regression with
constant parameters; forgetting pauses while a variance would exceed `p_cap` times its start
value (without that, P grows as λ^-n in unexcited directions and float32 loses the
estimate); a P whose round-off made a variance non-positive restarts at P(0), flagged
SINGULAR.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from vehil.estimators import register
from vehil.estimators.base import EstimatorSpec, Param, Signal, t_ref_param

WL = 5
WINDOW = 2 * WL + 1
ROWS = WINDOW - 2  # filtered rows in a window: φ̃[k] needs φ[k-2]
EPS_DEFAULT = math.atan(0.015)

# A sample no road vehicle makes (longit.h: FIXED's input bounds, a 4 t vehicle at 1.6 g):
# in every mode STLQF takes it clamped to them and RLS learns nothing from it
# (docs/estimators/stlqf.md and rls.md, "A sample past the bounds").
BOUNDS = np.array([82.0, 16.0, 65536.0])  # v, v̇, z


def past_bounds(u: np.ndarray) -> bool:
    return bool(np.any(np.abs(np.asarray(u, dtype=np.float64)) > BOUNDS))


INPUTS = (
    Signal("v", "m/s", q=24, doc="vehicle speed"),
    Signal("v_dot", "m/s^2", q=24, doc="vehicle acceleration"),
    Signal("z", "N", q=14, doc="measured tractive force F_x (eq. 27)"),
)
OUTPUTS = (
    Signal("m", "kg", q=16, doc="vehicle mass m̂"),
    Signal("cda", "m^2", q=16, doc="drag area Ĉ_dA_f (Q16: transients pass ±128 m²)"),
    Signal("grade", "deg", q=20, doc="road grade β̂_r"),
)
SHARED_PARAMS = (
    Param("eps", "rad", q=30, default=EPS_DEFAULT, lo=0.0, hi=0.1, doc="ε = atan(f)"),
    Param("rho", "kg/m^3", q=24, default=1.206, lo=0.5, hi=2.0, doc="air density"),
    Param("g", "m/s^2", q=24, default=9.81, lo=9.0, hi=10.5),
    Param("m0", "kg", q=16, default=1000.0, lo=100.0, hi=30000.0, doc="initial mass"),
    Param("cda0", "m^2", q=24, default=0.3, lo=0.0, hi=20.0, doc="initial drag area"),
    Param("T", "s", q=30, default=0.01, lo=1e-3, hi=1.0, doc="sample time"),
    Param("prefilter_hz", "Hz", q=16, default=0.0, lo=0.0, hi=50.0, doc="0: no prefilter"),
)


def no_fixed_prefilter(p: Mapping[str, float], mode: str) -> str | None:
    """FIXED: prefilter_hz = 0 (no prefilter in fixed point)."""
    if mode == "FIXED" and p["prefilter_hz"] != 0:
        return "prefilter_hz must be 0 in FIXED (no prefilter in fixed point)"
    return None


def per_sample_lambda(p: Mapping[str, float]) -> float:
    """RLS's λ as a step applies it: as given (t_ref = 0), or a forgetting per t_ref of time
    raised to T / t_ref, so RLS remembers as long at any sample time (docs/estimators/rls.md)."""
    return p["lambda"] ** (p["T"] / p["t_ref"]) if p["t_ref"] > 0.0 else p["lambda"]


def lambda_within_range(p: Mapping[str, float], mode: str) -> str | None:
    """λ^(T / t_ref) at least 0.5, λ's own range (FIXED's forgetting needs it)."""
    lam = per_sample_lambda(p)
    if lam < 0.5:
        return (
            f"lambda^(T / t_ref) = {lam:.4g} is below 0.5 per sample: lengthen t_ref or shorten T"
        )
    return None


def a_positive_definite(p: Mapping[str, float], mode: str) -> str | None:
    """a11..a33 make A positive definite."""
    a = [[p["a11"], p["a12"], p["a13"]], [p["a12"], p["a22"], p["a23"]]]
    a.append([p["a13"], p["a23"], p["a33"]])
    if np.any(np.linalg.eigvalsh(np.array(a)) <= 0):
        return "the weights a11..a33 must make A positive definite"
    return None


def chi2_fits(p: Mapping[str, float], mode: str) -> str | None:
    """FIXED: chi2 / T^2 < 2^20."""
    if mode == "FIXED" and p["chi2"] / p["T"] ** 2 >= 2.0**20:
        return "chi2 / T^2 must stay below 2^20 in FIXED (the filter's products would not fit)"
    return None


def mu_min_below_mu(p: Mapping[str, float], mode: str) -> str | None:
    """mu_min <= mu."""
    if p["mu_min"] > p["mu"]:
        return "mu_min must not exceed mu (the weight adapts between them)"
    return None


STLQF_PARAMS = (
    Param("chi1", "s", q=24, default=1.0, lo=0.0, hi=10.0, doc="χ1 (eq. 14)"),
    Param("chi2", "s^2", q=24, default=1.0, lo=0.0, hi=10.0, doc="χ2 (eq. 14)"),
    *(
        Param(f"a{ij}", "1", q=24, default=v, lo=-100.0, hi=100.0, doc="Table 3 weight")
        for ij, v in (("11", 5.0), ("12", 3.0), ("13", 2.0), ("22", 5.0), ("23", 3.0), ("33", 5.0))
    ),
    Param("mu", "1", q=30, default=1e-2, lo=0.0, hi=1.0, doc="Tikhonov weight (scaled): the hold"),
    Param("mu_min", "1", q=30, default=1e-2, lo=0.0, hi=1.0, doc="μ's floor, where data fix m"),
    Param(
        "held_max",
        "1",
        q=30,
        default=0.5,
        lo=0.0,
        hi=1.0,
        doc="ILL_CONDITIONED above this prior's share of m̂",
    ),
    Param(
        "jitter_max",
        "kg",
        q=16,
        default=0.5,
        lo=0.0,
        hi=1e4,
        doc="ILL_CONDITIONED while m̂'s mean step passes this (0: off)",
    ),
    Param("tau_jitter", "s", q=16, default=0.5, lo=1e-3, hi=100.0, doc="that mean's memory"),
    *SHARED_PARAMS,
)
CODE_WEIGHTS = {"a11": 1.0, "a12": -1.0, "a13": -1.0, "a22": 2.0, "a23": 1.0, "a33": 3.0}


def regressors(v: float, v_dot: float, p: Mapping[str, float]) -> np.ndarray:
    """ψ = [v̇, ½ρv², g/cos ε] (eq. 26)."""
    return np.array([v_dot, 0.5 * p["rho"] * v * v, p["g"] / math.cos(p["eps"])])


class Prefilter:
    """2nd-order Butterworth low-pass (bilinear, prewarped) on v̇, ½ρv² and z, the same on
    each so the regression stays consistent; starts settled on the first sample. Off at
    `prefilter_hz` = 0. The paper filters "in operational mode" without saying how (Fig. 9)."""

    def __init__(self, p: Mapping[str, float]):
        self.on = p["prefilter_hz"] > 0
        k = math.tan(math.pi * p["prefilter_hz"] * p["T"])
        norm = 1.0 / (1.0 + math.sqrt(2.0) * k + k * k)
        self.b0 = k * k * norm
        self.a1 = 2.0 * (k * k - 1.0) * norm
        self.a2 = (1.0 - math.sqrt(2.0) * k + k * k) * norm
        self.s: np.ndarray | None = None  # two states per channel

    def __call__(self, x: np.ndarray) -> np.ndarray:
        if not self.on:
            return x
        b0, b1, b2 = self.b0, 2.0 * self.b0, self.b0
        if self.s is None:
            self.s = np.array([(1.0 - b0) * x, (b2 - self.a2) * x])
        y = b0 * x + self.s[0]
        self.s = np.array([b1 * x - self.a1 * y + self.s[1], b2 * x - self.a2 * y])
        return y


def measured(
    u: np.ndarray, p: Mapping[str, float], prefilter: Prefilter
) -> tuple[np.ndarray, float]:
    """ψ and z of a sample [v, v̇, z], through the prefilter."""
    v, v_dot, z = (float(x) for x in u)
    psi = regressors(v, v_dot, p)
    x = prefilter(np.r_[psi[:2], z])
    return np.r_[x[:2], psi[2]], float(x[2])


def grade_deg(theta: np.ndarray, p: Mapping[str, float]) -> float:
    """β̂_r = asin(θ3/θ1) - ε in degrees, the ratio clamped to [-1, 1]."""
    ratio = min(max(theta[2] / theta[0], -1.0), 1.0) if theta[0] > 0 else 0.0
    return math.degrees(math.asin(ratio) - p["eps"])


def weight_factor(p: Mapping[str, float]) -> np.ndarray:
    """R (9×9, upper, bandwidth 2) with Rᵀ R = Σ_k E_kᵀ A E_k over the window's 7 terms."""
    a = np.array(
        [
            [p["a11"], p["a12"], p["a13"]],
            [p["a12"], p["a22"], p["a23"]],
            [p["a13"], p["a23"], p["a33"]],
        ]
    )
    weight = np.zeros((ROWS, ROWS))
    for k in range(2, ROWS):  # term k stacks rows k, k-1, k-2
        idx = [k, k - 1, k - 2]
        weight[np.ix_(idx, idx)] += a
    return np.linalg.cholesky(weight).T


def weights_ok(p: Mapping[str, float]) -> bool:
    a = [
        [p["a11"], p["a12"], p["a13"]],
        [p["a12"], p["a22"], p["a23"]],
        [p["a13"], p["a23"], p["a33"]],
    ]
    return bool(np.all(np.linalg.eigvalsh(np.array(a)) > 0))


SINGULAR = 0x04  # STATUS_SINGULAR
CLAMPED = 0x08  # STATUS_CLAMPED
ILL_CONDITIONED = 0x10  # STATUS_ILL_CONDITIONED


def cholesky_solve(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float, np.ndarray] | None:
    """x with a x = b, the condition estimate (max L_ii / min L_ii)² and L; None when a
    pivot is not positive. The board's chol_f32 does the same steps."""
    n = len(b)
    low = np.zeros_like(a)
    for j in range(n):
        pivot = a[j, j] - low[j, :j] @ low[j, :j]
        if not pivot > 0:
            return None
        low[j, j] = math.sqrt(pivot)
        for i in range(j + 1, n):
            low[i, j] = (a[i, j] - low[i, :j] @ low[j, :j]) / low[j, j]
    y = np.zeros(n)
    for i in range(n):
        y[i] = (b[i] - low[i, :i] @ y[:i]) / low[i, i]
    x = np.zeros(n)
    for i in reversed(range(n)):
        x[i] = (y[i] - low[i + 1 :, i] @ x[i + 1 :]) / low[i, i]
    diag = np.diag(low)
    return x, float((diag.max() / diag.min()) ** 2), low


MASS = 1  # θ's entry of the mass at the window centre
# The system's unknowns, θ's entries in solve order: the mass last, so its Cholesky pivot
# is its information given the rest and [(S + μ I)⁻¹]_mm = 1 / L_mm².
ORDER = (0, 2, 3, 4, 5, MASS)


def prior_share(low: np.ndarray, mu: float) -> float:
    """μ [(S + μ I)⁻¹]_mm = μ / L_mm² from L L^T = S + μ I (the mass last): the share of
    m̂ that the prior holds (the diagonal of I minus the resolution matrix), in [0, 1]."""
    return float(mu / low[-1, -1] ** 2)


def next_mu(pivot: float, mu: float, p: Mapping[str, float]) -> float:
    """The next window's μ from this one's (docs/estimators/stlqf.md): the mass's
    information given the rest, ι = L_mm² - μ (the scaled system's last pivot less the
    pull), sets μ' = mu (mu / ι)², within [mu_min, mu]: the full hold where ι <= mu (the
    prior would take half of m̂ or more), falling fast as the data take over."""
    info, top = pivot - mu, p["mu"]
    ratio = min(top / info, 1.0) if info > 0.0 else 1.0
    return max(top * ratio * ratio, p["mu_min"])


class Stlqf:
    """STLQF, float64. step([v, v̇, z]) -> [m̂, Ĉ_dA_f, β̂_r (deg), log10 cond]."""

    def __init__(self, p: Mapping[str, float]):
        self.p = p
        self.prefilter = Prefilter(p)
        self.R = weight_factor(p)
        self.theta = np.array([0.0, p["m0"], 0.0, p["cda0"], 0.0, p["m0"] * math.sin(p["eps"])])
        self.hist: list[tuple[np.ndarray, float]] = []  # (ψ, z) of the last two samples
        self.rows: list[np.ndarray] = []  # [ψ̃ (3), e (3), ζ] of the last ROWS samples
        self.exact_cond: list[float] = []
        self.flags = 0
        self.held = 1.0  # the prior's share of m̂ in the last window
        self.jitter = -1.0  # m̂'s mean step (kg), < 0 until a window has been solved
        self.mu = p["mu"]  # this window's: held until the data show they fix the mass

    def _filtered(self, x: np.ndarray, x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
        """x + χ1 Δx/T + χ2 Δ²x/T² (α x + β x₋₁ + γ x₋₂ as differences)."""
        p, T = self.p, self.p["T"]
        d1 = x - x1
        return x + p["chi1"] * d1 / T + p["chi2"] * (d1 - (x1 - x2)) / (T * T)

    def _push(self, psi: np.ndarray, z: float) -> None:
        if len(self.hist) == 2:
            (psi1, z1), (psi2, z2) = self.hist
            p, T = self.p, self.p["T"]
            # The time column's filter: φ̃_τ = τ ψ̃ + χ1 ψ₋₁/T + 2χ2 (ψ₋₁ - ψ₋₂)/T².
            e = p["chi1"] * psi1 / T + 2 * p["chi2"] * (psi1 - psi2) / (T * T)
            zeta = self._filtered(np.array([z]), np.array([z1]), np.array([z2]))[0]
            self.rows = [*self.rows[-(ROWS - 1) :], np.r_[self._filtered(psi, psi1, psi2), e, zeta]]
        self.hist = [(psi, z), *self.hist[:1]]

    def window_system(self) -> tuple[np.ndarray, np.ndarray]:
        """Eq. 23's G and U for the current window, columns [τ ψ1, ψ1, τ ψ2, ψ2, τ ψ3, ψ3]."""
        rows = np.array(self.rows)
        tau = np.arange(ROWS) - (ROWS - 1 - WL)  # sample minus the window centre
        phi = np.empty((ROWS, 6))
        phi[:, 0::2] = tau[:, None] * rows[:, 0:3] + rows[:, 3:6]
        phi[:, 1::2] = rows[:, 0:3]
        x, r = self.R @ phi, self.R @ rows[:, 6]
        return x.T @ x, x.T @ r

    def noisy(self, step: float) -> bool:
        """Whether m̂'s mean step per window, over tau_jitter of time, passes jitter_max: the
        window's data fix the mass, but noise moves it (docs/estimators/stlqf.md). The first
        window's step, from m0, is not counted."""
        p = self.p
        if self.jitter < 0.0:
            self.jitter = 0.0
            return False
        self.jitter += min(p["T"] / p["tau_jitter"], 1.0) * (step - self.jitter)
        return p["jitter_max"] > 0.0 and self.jitter > p["jitter_max"]

    def step(self, u: np.ndarray) -> np.ndarray:
        p = self.p
        clamped = past_bounds(u)
        self._push(*measured(np.clip(u, -BOUNDS, BOUNDS), p, self.prefilter))
        self.flags = CLAMPED if clamped else 0
        log_cond = 0.0
        if len(self.rows) == ROWS:
            gram, rhs = self.window_system()
            diag = np.diag(gram)
            d = np.where(diag > 0, 1.0 / np.sqrt(np.where(diag > 0, diag, 1.0)), 1.0)
            scaled = gram * np.outer(d, d)
            self.exact_cond.append(float(np.linalg.cond(scaled)))
            # Prior: each value where the last window's line puts it one sample later,
            # each slope zero (a random walk: a slope the data do not carry decays).
            prior = np.zeros(6)
            prior[1::2] = self.theta[1::2] + self.theta[0::2]
            mu, order = self.mu, list(ORDER)
            system = (scaled + mu * np.eye(6))[np.ix_(order, order)]
            solved = cholesky_solve(system, (d * rhs + mu * prior / d)[order])
            if solved is None:
                self.flags |= SINGULAR
                log_cond = math.inf
            else:
                y, cond, low = solved
                log_cond = math.log10(cond)
                self.held = prior_share(low, mu)
                if self.held > p["held_max"]:
                    self.flags |= ILL_CONDITIONED
                m_last = self.theta[MASS]
                self.theta[order] = d[order] * y
                self.mu = next_mu(float(low[-1, -1] ** 2), mu, p)
                if self.noisy(abs(self.theta[MASS] - m_last)):
                    self.flags |= ILL_CONDITIONED
        theta = self.theta[1::2]
        return np.array([theta[0], theta[1], grade_deg(theta, p), log_cond])


class Rls:
    """RLS with forgetting λ, float64. step([v, v̇, z]) -> [m̂, Ĉ_dA_f, β̂_r (deg)]."""

    def __init__(self, p: Mapping[str, float]):
        self.p = p
        self.theta = np.array([p["m0"], p["cda0"], p["m0"] * math.sin(p["eps"])])
        self.P = np.diag([p["p0_m"], p["p0_cda"], p["p0_m"]])
        self.cap = p["p_cap"] * np.diag(self.P)
        self.prefilter = Prefilter(p)
        self.flags = 0

    def step(self, u: np.ndarray) -> np.ndarray:
        if past_bounds(u):  # held: not learnt from
            self.flags = (self.flags & ILL_CONDITIONED) | CLAMPED
            return np.array([self.theta[0], self.theta[1], grade_deg(self.theta, self.p)])
        psi, z = measured(u, self.p, self.prefilter)
        lam = per_sample_lambda(self.p)
        ppsi = self.P @ psi
        k = ppsi / (lam + psi @ ppsi)
        self.theta = self.theta + k * (z - psi @ self.theta)
        P = self.P - np.outer(k, ppsi)
        P = (P + P.T) / 2
        # Forgetting stops while a variance would pass p_cap times its start (windup
        # guard: without it P grows as λ^-n in directions the drive does not excite).
        P[2, 2] += self.p["q_grade"] * self.p["T"]  # θ3's random walk (the road's grade moves)
        self.P = P if np.any(np.diag(P) / lam > self.cap) else P / lam
        p0 = self.cap / self.p["p_cap"]
        if not np.all(np.diag(self.P) > 0):  # round-off broke P: start it again
            self.P = np.diag(p0)
        # The prior's share of each estimate, P_ii / P(0)_ii (docs/estimators/rls.md).
        self.flags = ILL_CONDITIONED if np.any(np.diag(self.P) > self.p["held_max"] * p0) else 0
        return np.array([self.theta[0], self.theta[1], grade_deg(self.theta, self.p)])


STLQF = register(
    EstimatorSpec(
        name="stlqf",
        budget={"FIXED": 60_000, "F32": 110_000},
        c_id=30,
        title="STLQF: mass, drag area and grade from an 11-sample window (seed 002)",
        inputs=INPUTS,
        outputs=(*OUTPUTS, Signal("log_cond", "1", q=24, doc="log10 condition estimate")),
        reference=Stlqf,
        params=STLQF_PARAMS,
        rules=(a_positive_definite, chi2_fits, no_fixed_prefilter, mu_min_below_mu),
        modes=("F32", "FIXED"),
        paper="002-stlqf-hil-mega2560",
        delay=WL,
    )
)

RLS = register(
    EstimatorSpec(
        name="rls",
        budget={"FIXED": 10_000},
        c_id=31,
        title="RLS with forgetting: mass, drag area and grade (seed 002's baseline)",
        inputs=INPUTS,
        outputs=OUTPUTS,
        reference=Rls,
        params=(
            Param("lambda", "1", q=30, default=0.95, lo=0.5, hi=1.0, doc="forgetting factor"),
            Param("p0_m", "kg^2", q=0, default=1e4, lo=0.0, hi=1e9, doc="P(0) of m and m sin"),
            Param("p0_cda", "m^4", q=16, default=1.0, lo=0.0, hi=1e4, doc="P(0) of C_dA_f"),
            Param("p_cap", "1", q=0, default=100.0, lo=1.0, hi=1e6, doc="windup guard"),
            Param(
                "held_max",
                "1",
                q=16,
                default=0.5,
                lo=1e-3,
                hi=1e4,
                doc="ILL_CONDITIONED while a variance is above held_max times its P(0)",
            ),
            t_ref_param("0: λ per sample; > 0: λ per t_ref of time, λ^(T/t_ref) a step"),
            Param(
                "q_grade",
                "kg^2/(N^2 s)",
                q=8,
                default=0.0,
                lo=0.0,
                hi=1e6,
                doc="θ3 = m sin(ε + β_r) a random walk: its variance grows q_grade T a step",
            ),
            *SHARED_PARAMS,
        ),
        rules=(no_fixed_prefilter, lambda_within_range),
        modes=("F32", "FIXED"),
        paper="002-stlqf-hil-mega2560",
    )
)
