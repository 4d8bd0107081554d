"""The Kalman filters' health check, one mechanism for all of them (ACC KF, UIIEKF, KF-UI):
the normalised innovation squared (NIS) averaged over a window, and a state more than 3σ
outside its plausible range. Either sets DIVERGED. The C twin is
firmware/lib/estimators/health.h."""

from __future__ import annotations

import numpy as np


class NisWindow:
    """An exponential average of the NIS with weight T / window (window >= T)."""

    def __init__(self, T: float, window: float):
        self.alpha = T / window
        self.mean = 0.0

    def update(self, nis: float) -> float:
        self.mean += self.alpha * (nis - self.mean)
        return self.mean


def nis_outside(e: np.ndarray, S_inv: np.ndarray, b: np.ndarray) -> float:
    """eᵀ S⁻¹ e less its part along b, the direction an unknown input takes in the
    innovation (its estimate absorbs that part): a χ² value with one degree fewer."""
    w = S_inv @ b
    return float(e @ S_inv @ e - (w @ e) ** 2 / (b @ w))


def outside_3sigma(x: float, lo: float, hi: float, var: float) -> bool:
    """x more than 3σ (σ² = var) below lo or above hi."""
    out = x - lo if x < lo else max(x - hi, 0.0)
    return out * out > 9.0 * var
