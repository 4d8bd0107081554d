"""The Kalman filters' health checks: the normalised innovation squared (NIS) averaged over
a window (UIIEKF, KF-UI), the innovation's mean over a window against its white-noise
spread (ACC KF), and a state more than 3σ outside its plausible range. Each sets DIVERGED.
The C twin is firmware/lib/estimators/health.h (the ACC KF's is in acc_kf.c)."""

from __future__ import annotations

import numpy as np


class WindowMean:
    """An exponential average with weight T / window (window >= T): of the NIS, or of the
    innovation (MeanInnovation)."""

    def __init__(self, T: float, window: float):
        self.alpha = T / window
        self.mean = 0.0

    def update(self, x: float) -> float:
        self.mean += self.alpha * (x - self.mean)
        return self.mean


class MeanInnovation:
    """The innovation's exponential average ē (weight α = T / window) squared over the
    variance it has when the innovations are white with variance S, S α / (2 - α): a χ²(1)
    value when the filter is healthy, whatever T. A bias μ in the innovations (a model the
    data do not follow) reads μ² (2 - α) / (S α): per sample μ scales as √T at a given
    model error, so this stays the same at any T, where the NIS's μ²/S grows with T."""

    def __init__(self, T: float, window: float):
        self.mean = WindowMean(T, window)

    def update(self, e: float, S: float) -> float:
        mean, alpha = self.mean.update(e), self.mean.alpha
        return mean * mean * (2.0 - alpha) / (alpha * S)


def nis_outside(e: np.ndarray, S_inv: np.ndarray, b: np.ndarray) -> float:
    """eᵀ S⁻¹ e less its part along b, the direction an unknown input takes in the
    innovation (its estimate absorbs that part): a χ² value with one degree fewer."""
    w = S_inv @ b
    return float(e @ S_inv @ e - (w @ e) ** 2 / (b @ w))


def outside_3sigma(x: float, lo: float, hi: float, var: float) -> bool:
    """x more than 3σ (σ² = var) below lo or above hi."""
    out = x - lo if x < lo else max(x - hi, 0.0)
    return out * out > 9.0 * var
