"""Seed 001: EKF, UKF and the unscented particle filter on the 7-state EV model.

All three share the model of `models/ev4wd.py` (the paper's Sec. 3, eqs. 26-30) with the car their
parameters name (`Car`: every vehicle and tire constant), its input preprocessing,
Q, P_0 and R: fixed, or adaptive by (66)-(69) (`adaptive`). A step
takes the sensors of sample k: it predicts from the last estimate with the last
inputs u_{k-1} (31), then corrects with y_k (32), and outputs the corrected state
and β. The first sample only corrects the prior.

- EKF (the paper's baseline in Fig. 4): analytic Jacobians (see `jacobians`),
  P = F P Fᵀ + Q, then the seven measurements as sequential scalar updates (R is
  diagonal, so this is the batch update; the board does the same and never inverts a 7×7).
- EKF3 (the board's reduced EKF): x = [v_x, v_y, γ], the lateral forces not states
  but the quasi-static G_yκ F_y0 at the estimate ((20) at steady state), so F is 3×3
  and H 7×3. One tire evaluation per step (they dominate the board's cycles), at the
  predicted state: the forces there are carried to the corrected state to first order
  (the force outputs), and the next prediction uses these forces and the same slopes
  (u_{k-1} is the input of both); so it takes neither p0_f nor q_f. The board does the
  measurement update in information form, P⁺ = (P⁻¹ + Hᵀ R⁻¹ H)⁻¹ (two 3×3 inverses
  are cheaper there than seven scalar updates): the same batch update as `ekf_correct`.
- UKF: the non-augmented, additive-noise UKF with the paper's UT parameters (κ = 0,
  β = 2, α from `alpha`), sigma points from Cholesky, drawn again from the predicted
  (x, P) for the measurement. Means are taken as χ_0 + Σ W_j (χ_j - χ_0), which is
  Σ W_j χ_j (the weights sum to 1) without the cancellation that α = 1e-3 (W_0 ≈ -1.4e5)
  causes. float32 cannot carry α = 1e-3 even so (the spread is 2.6e-3 σ): the board
  spec's default is α = 1, a deviation from the paper's 0.001 that float64 tables do
  not need.
- UPF (host only, the paper's Sec. 4): N particles, each with its own UKF on the augmented
  state (n_a = 21, 43 sigma points, α = 1e-3, β = 2, κ = 0 as printed) as proposal
  (57), weights (60) in the log domain with p(y|x) = N(h(x), R_k) and p(x_k|x_{k-1})
  = N(f(x_{k-1}), Q), the weighted mean (62) as output, systematic resampling every
  step (each particle takes its covariance along). Vectorised over particles and
  sigma points.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping

import numpy as np

from vehil.estimators import register
from vehil.estimators.base import EstimatorSpec, Param
from vehil.models import ev4wd as ev

NOT_FINITE = 0x02  # STATUS_NOT_FINITE
SINGULAR = 0x04  # STATUS_SINGULAR


def ut_weights(
    n: int, alpha: float, beta: float, kappa: float
) -> tuple[float, np.ndarray, np.ndarray]:
    """(42)-(46): the spread sqrt(n + λ) and the mean and covariance weights (2n + 1)."""
    lam = alpha * alpha * (n + kappa) - n
    wm = np.full(2 * n + 1, 1.0 / (2 * (n + lam)))
    wc = wm.copy()
    wm[0] = lam / (n + lam)
    wc[0] = lam / (n + lam) + 1 - alpha * alpha + beta
    return math.sqrt(n + lam), wm, wc


def sigma_points(x: np.ndarray, P: np.ndarray, spread: float) -> np.ndarray | None:
    """(41): x, x ± spread · columns of chol(P), shape (2n + 1, n); None if P is not PD."""
    try:
        L = np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        return None
    d = spread * L.T
    return np.concatenate([x[None], x + d, x - d])


def ut_mean(chi: np.ndarray, wm: np.ndarray) -> np.ndarray:
    """Σ W_j χ_j written as χ_0 + Σ_{j>0} W_j (χ_j - χ_0): the same sum, no cancellation."""
    return chi[..., 0, :] + np.einsum("...jk,j->...k", chi[..., 1:, :] - chi[..., :1, :], wm[1:])


def _accept(filt: _Filter | Upf, z: np.ndarray) -> ev.Inputs | None:
    """A sample's inputs through the filter's preprocessing; None, flagged NOT_FINITE and
    with the state left alone, if a sensor value is NaN or infinite."""
    z = np.asarray(z, dtype=np.float64)
    filt.flags = 0
    if not np.all(np.isfinite(z)):
        filt.flags = NOT_FINITE
        return None
    return filt.pre(z)


def _noise(
    x: np.ndarray,
    u: ev.Inputs,
    car: ev.Car,
    mu: float,
    p: Mapping[str, float],
    linear: bool = False,
) -> np.ndarray:
    """R at this sample: (66)-(69) from the slips at x, or the fixed R."""
    return ev.adaptive_r(u, ev.wheels(x, u, car, mu, linear).kappa, p)


class _Filter(ABC):
    """What the EKF and UKF share: the inputs, the prior, R and the outputs."""

    N = ev.N_X  # states
    linear = False  # linear tires (Ekf3's `tires`)

    def __init__(self, p: Mapping[str, float]):
        self.p = p
        self.mu, self.T, self.car = p["mu"], p["T"], ev.Car.of(p)
        self.pre = ev.Preprocess(self.T, self.car)
        self.x, self.P = ev.x0(p, self.N)
        self.Q = np.diag(ev.q_diag(p, self.N))
        self.u_prev: ev.Inputs | None = None
        self.flags = 0
        self.r_history: list[np.ndarray] = []

    def step(self, z: np.ndarray) -> np.ndarray:
        u = _accept(self, z)
        if u is None:
            return ev.outputs(self.x)
        if self.u_prev is not None:
            self.predict(self.u_prev)
        self.update(u)
        self.P = 0.5 * (self.P + self.P.T)
        self.u_prev = u
        return ev.outputs(self.x)

    def noise(self, u: ev.Inputs) -> np.ndarray:
        R = _noise(self.x, u, self.car, self.mu, self.p, self.linear)
        self.r_history.append(R)
        return R

    @abstractmethod
    def predict(self, u: ev.Inputs) -> None: ...

    @abstractmethod
    def update(self, u: ev.Inputs) -> None: ...


def ekf_correct(
    x: np.ndarray, P: np.ndarray, H: np.ndarray, e: np.ndarray, R: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Sequential scalar updates with the innovations e at the predicted x: the batch
    update, R being diagonal."""
    x_pred = x.copy()
    for j in range(len(e)):
        hj = H[j]
        ph = P @ hj
        k = ph / (hj @ ph + R[j])
        x = x + k * (e[j] - hj @ (x - x_pred))
        P = P - np.outer(k, ph)
    return x, P


class Ekf(_Filter):
    """step(12 sensors) -> [v_x, v_y, γ, F_1y..F_4y, β]."""

    def predict(self, u: ev.Inputs) -> None:
        F, _ = ev.jacobians(self.x, u, self.car, self.mu, self.T)
        self.x = ev.step(self.x, u, self.car, self.mu, self.T)
        self.P = F @ self.P @ F.T + self.Q

    def update(self, u: ev.Inputs) -> None:
        R = self.noise(u)
        _, H = ev.jacobians(self.x, u, self.car, self.mu, self.T)
        e = u.y - ev.h(self.x, u, self.car, self.mu)
        self.x, self.P = ekf_correct(self.x, self.P, H, e, R)


class Ekf3(_Filter):
    """step(12 sensors) -> [v_x, v_y, γ, F_1y..F_4y, β], 3 states (see above)."""

    N = 3

    def __init__(self, p: Mapping[str, float]):
        super().__init__(p)
        self.linear = p["tires"] >= 0.5
        self.fy = np.zeros(4)
        self.slopes: ev.Slopes | None = None

    def predict(self, u: ev.Inputs) -> None:
        assert self.slopes is not None  # an update came first
        F, _ = ev.jacobians3(self.x, u, self.car, self.T, self.slopes, None)
        self.x = ev.step3(self.x, u, self.car, self.T, self.fy)
        self.P = F @ self.P @ F.T + self.Q

    def update(self, u: ev.Inputs) -> None:
        R = self.noise(u)
        w = ev.wheels(self.x, u, self.car, self.mu, self.linear)
        s = ev.slopes(self.x, u, self.car, self.mu, w, self.linear)
        _, H = ev.jacobians3(self.x, u, self.car, self.T, s, w)
        assert H is not None
        e = u.y - ev.h(self.x, u, self.car, self.mu, quasi_static=True, linear=self.linear)
        x_pred = self.x
        self.x, self.P = ekf_correct(self.x, self.P, H, e, R)
        self.fy = w.fy_qs + s.dqs * (s.dalpha @ (self.x - x_pred))
        self.slopes = s

    def step(self, z: np.ndarray) -> np.ndarray:
        out = super().step(z)
        return np.r_[out[:3], self.fy, out[-1]]


class Ukf(_Filter):
    """step(12 sensors) -> [v_x, v_y, γ, F_1y..F_4y, β]."""

    def __init__(self, p: Mapping[str, float]):
        super().__init__(p)
        self.spread, self.wm, self.wc = ut_weights(ev.N_X, p["alpha"], 2.0, 0.0)

    def predict(self, u: ev.Inputs) -> None:
        chi = sigma_points(self.x, self.P, self.spread)
        if chi is None:
            self.flags |= SINGULAR
            self.P = np.diag(np.diag(self.P))
            return
        chi = ev.step(chi, u, self.car, self.mu, self.T)
        self.x = ut_mean(chi, self.wm)
        d = chi - self.x
        self.P = (self.wc[:, None] * d).T @ d + self.Q

    def update(self, u: ev.Inputs) -> None:
        R = self.noise(u)
        chi = sigma_points(self.x, self.P, self.spread)
        if chi is None:
            self.flags |= SINGULAR
            self.P = np.diag(np.diag(self.P))
            return
        Y = ev.h(chi, u, self.car, self.mu)
        y = ut_mean(Y, self.wm)
        dy, dx = Y - y, chi - self.x
        Pyy = (self.wc[:, None] * dy).T @ dy + np.diag(R)
        Pxy = (self.wc[:, None] * dx).T @ dy
        K = np.linalg.solve(Pyy, Pxy.T).T
        self.x = self.x + K @ (u.y - y)
        self.P = self.P - K @ Pyy @ K.T


class Upf:
    """The unscented particle filter (host only). step(12 sensors) -> the EKF's outputs."""

    def __init__(self, p: Mapping[str, float], n: int = 100, seed: int = 0):
        self.p, self.n = p, n
        self.mu, self.T, self.car = p["mu"], p["T"], ev.Car.of(p)
        self.rng = np.random.default_rng(seed)
        self.pre = ev.Preprocess(self.T, self.car)
        x0, P0 = ev.x0(p)
        self.X = x0 + self.rng.standard_normal((n, ev.N_X)) * np.sqrt(np.diag(P0))  # (37)
        self.P = np.broadcast_to(P0, (n, ev.N_X, ev.N_X)).copy()
        self.q = ev.q_diag(p)
        nx, na = ev.N_X, 2 * ev.N_X + ev.N_Y  # (43)
        self.spread, self.wm, self.wc = ut_weights(na, 1e-3, 2.0, 0.0)
        # Of the 2 n_a + 1 sigma points only 1 + 2 n_x move the state: the process-noise
        # ones go through f with the particle's state, the measurement-noise ones through
        # h with its prediction. f and h run once for each distinct argument, ~2x faster.
        m = 2 * na + 1
        moves_x = np.r_[0, 1 : 1 + nx, 1 + na : 1 + na + nx]
        self.f_of = np.zeros(m, dtype=int)  # sigma point -> its row of f's arguments
        self.f_of[moves_x] = np.arange(len(moves_x))
        v_points = np.r_[1 + 2 * nx : 1 + na, 1 + na + 2 * nx : m]
        self.h_args = np.setdiff1d(np.arange(m), v_points)
        self.h_of = np.zeros(m, dtype=int)  # the v points share point 0's h
        self.h_of[self.h_args] = np.arange(len(self.h_args))
        self.u_prev: ev.Inputs | None = None
        self.x = x0
        self.flags = 0

    def step(self, z: np.ndarray) -> np.ndarray:
        u = _accept(self, z)
        if u is None:
            return ev.outputs(self.x)
        self._step(u, _noise(self.x, u, self.car, self.mu, self.p))
        self.u_prev = u
        return ev.outputs(self.x)

    def _step(self, u: ev.Inputs, r: np.ndarray) -> None:
        n, nx, ny = self.n, ev.N_X, ev.N_Y
        # 1) Augmented sigma points (39)-(41): P^a = diag(P, Q, R), so its factor is
        # blockdiag(chol P, √Q, √R) and only P needs a Cholesky.
        try:
            L = np.linalg.cholesky(self.P + 1e-9 * np.eye(nx))
        except np.linalg.LinAlgError:
            self.flags |= SINGULAR
            self.P = np.einsum("nii->ni", self.P)[:, :, None] * np.eye(nx)
            L = np.linalg.cholesky(self.P + 1e-9 * np.eye(nx))
        na = 2 * nx + ny
        m = 2 * na + 1
        s = self.spread
        d = s * np.swapaxes(L, 1, 2)  # row j: column j of chol P
        chi_x = np.concatenate([self.X[:, None], self.X[:, None] + d, self.X[:, None] - d], 1)
        chi_w = np.zeros((n, m, nx))
        chi_v = np.zeros((n, m, ny))
        for j in range(nx):
            chi_w[:, 1 + nx + j, j] = s * math.sqrt(self.q[j])
            chi_w[:, 1 + na + nx + j, j] = -s * math.sqrt(self.q[j])
        for j in range(ny):
            chi_v[:, 1 + 2 * nx + j, j] = s * math.sqrt(r[j])
            chi_v[:, 1 + na + 2 * nx + j, j] = -s * math.sqrt(r[j])
        # 2) Time update (47)-(51) (the first sample has no u_{k-1}: the prior stands).
        if self.u_prev is not None:
            chi_x = ev.step(chi_x, self.u_prev, self.car, self.mu, self.T)
        pred = chi_x[:, self.f_of] + chi_w
        x_pred = ut_mean(pred, self.wm)
        Y = ev.h(pred[:, self.h_args], u, self.car, self.mu)[:, self.h_of] + chi_v
        y_pred = ut_mean(Y, self.wm)
        dx, dy = pred - x_pred[:, None], Y - y_pred[:, None]
        wdx = np.swapaxes(self.wc[None, :, None] * dx, 1, 2)
        P_pred = wdx @ dx
        # 3) Measurement update (52)-(56).
        Pxy = wdx @ dy
        Pyy = np.swapaxes(self.wc[None, :, None] * dy, 1, 2) @ dy
        K = np.linalg.solve(Pyy, np.swapaxes(Pxy, 1, 2)).swapaxes(1, 2)
        x_upd = x_pred + np.einsum("nij,nj->ni", K, u.y - y_pred)
        P_upd = P_pred - K @ Pyy @ np.swapaxes(K, 1, 2)
        P_upd = 0.5 * (P_upd + np.swapaxes(P_upd, 1, 2)) + 1e-9 * np.eye(nx)
        # 4) Importance sampling (57)-(61), in logs.
        Lu = np.linalg.cholesky(P_upd)
        eps = self.rng.standard_normal((n, nx))
        xs = x_upd + np.einsum("nij,nj->ni", Lu, eps)
        log_q = -0.5 * (eps**2).sum(1) - np.log(np.einsum("nii->ni", Lu)).sum(1)
        prior = (
            self.X
            if self.u_prev is None
            else ev.step(self.X, self.u_prev, self.car, self.mu, self.T)
        )
        log_trans = -0.5 * (((xs - prior) ** 2) / self.q).sum(1)
        log_lik = -0.5 * (((u.y - ev.h(xs, u, self.car, self.mu)) ** 2) / r).sum(1)
        logw = log_lik + log_trans - log_q
        w = np.exp(logw - logw.max())
        w /= w.sum()
        # 6) Output (62), before resampling: the weighted mean has the lower variance.
        self.x = w @ xs
        # 5) Systematic resampling, every step; each particle keeps its P.
        edges = (self.rng.random() + np.arange(n)) / n
        idx = np.minimum(np.searchsorted(np.cumsum(w), edges), n - 1)
        self.X, self.P = xs[idx], P_upd[idx]


EKF_PARAMS = (*ev.PARAMS, *ev.FORCE_PARAMS)
BOARD_PARAMS = (
    *EKF_PARAMS,
    Param("alpha", "1", default=1.0, lo=1e-4, hi=1.0, doc="UT spread α (paper 1e-3; see above)"),
)
DOC = __doc__ or ""


def _board_filter(
    name: str, c_id: int, title: str, reference: type[_Filter], params: tuple[Param, ...]
) -> EstimatorSpec:
    """A seed-001 filter the board runs: the EV model's signals, float32."""
    return register(
        EstimatorSpec(
            name=name,
            c_id=c_id,
            title=title,
            inputs=ev.INPUTS,
            outputs=ev.OUTPUTS,
            reference=reference,
            params=params,
            modes=("F32",),
            paper="001-upf-distributed-ev",
            doc=DOC,
        )
    )


EKF = _board_filter(
    "ev_ekf", 50, "EKF on the 7-state EV model, fixed or adaptive R (seed 001)", Ekf, EKF_PARAMS
)
EKF3 = _board_filter(
    "ev_ekf3",
    52,
    "EKF on the 3-state EV model, quasi-static lateral forces (seed 001, board)",
    Ekf3,
    (
        *ev.PARAMS,
        Param("tires", "1", default=0.0, lo=0.0, hi=1.0, doc="0 combined-slip MF, 1 linear range"),
    ),
)
UKF = _board_filter(
    "ev_ukf", 51, "UKF on the 7-state EV model, fixed or adaptive R (seed 001)", Ukf, BOARD_PARAMS
)
