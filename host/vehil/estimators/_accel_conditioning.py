"""Displacements from accelerations, causally: seed 003's signal chain (the paper's 0.5-20 Hz
band-pass and double integration, Secs. 2 and 6.1; docs/estimators/eso.md).

a -> 2nd-order Butterworth high-pass f_hp (removes the accelerometer bias) -> 2nd-order
Butterworth low-pass f_lp (noise) -> trapezoid -> first-order high-pass f_post -> trapezoid
-> first-order high-pass f_post. The paper gives the band, not the filters: the
Butterworths and the post high-pass are ours (the bias leaves an offset after double
integration otherwise; f_post = 0 switches it off). `filtered = 0`
integrates the raw acceleration (Fig. 5's diverging case). The filters are designed by the
bilinear transform with prewarping, as the C does in configure. The high-pass runs in
delta form (its poles sit near z = 1; see accel_cond.h), the low-pass in direct form I.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vehil.estimators.base import Param


@dataclass(frozen=True)
class Biquad:
    """y = b0 x + b1 x1 + b2 x2 - a1 y1 - a2 y2 (direct form I)."""

    b0: float
    b1: float
    b2: float
    a1: float
    a2: float


def butter2(fc: float, T: float, highpass: bool) -> Biquad:
    k = math.tan(math.pi * fc * T)
    norm = 1.0 / (1.0 + math.sqrt(2.0) * k + k * k)
    a1 = 2.0 * (k * k - 1.0) * norm
    a2 = (1.0 - math.sqrt(2.0) * k + k * k) * norm
    if highpass:
        return Biquad(norm, -2.0 * norm, norm, a1, a2)
    b0 = k * k * norm
    return Biquad(b0, 2.0 * b0, b0, a1, a2)


def post_alpha(f_post: float, T: float) -> float:
    """y = α (y1 + x - x1): a first-order high-pass (RC form); α = 1 passes x unchanged."""
    if f_post <= 0.0:
        return 1.0
    rc = 1.0 / (2.0 * math.pi * f_post)
    return rc / (rc + T)


class _Section:
    def __init__(self, c: Biquad):
        self.c = c
        self.x1 = self.x2 = self.y1 = self.y2 = 0.0

    def step(self, x: float) -> float:
        c = self.c
        y = c.b0 * x + c.b1 * self.x1 + c.b2 * self.x2 - c.a1 * self.y1 - c.a2 * self.y2
        self.x2, self.x1, self.y2, self.y1 = self.x1, x, self.y1, y
        return y


class _HighPass:
    """The Butterworth high-pass in delta form: Δ <- (1 - c2) Δ + g ∇²x - c12 y1, y = y1 + Δ
    (c2 = 1 - a2, c12 = 1 + a1 + a2, computed without cancellation)."""

    def __init__(self, fc: float, T: float):
        k = math.tan(math.pi * fc * T)
        self.g = 1.0 / (1.0 + math.sqrt(2.0) * k + k * k)
        self.c2 = 2.0 * math.sqrt(2.0) * k * self.g
        self.c12 = 4.0 * k * k * self.g
        self.x1 = self.x2 = self.y1 = self.d = 0.0

    def step(self, x: float) -> float:
        self.d = (1 - self.c2) * self.d + self.g * ((x - self.x1) - (self.x1 - self.x2))
        self.d -= self.c12 * self.y1
        self.y1 += self.d
        self.x2, self.x1 = self.x1, x
        return self.y1


class _Integrator:
    """Trapezoid, then the first-order high-pass y = α (y1 + s - s1) of its sum s (only
    the increment s - s1 is needed, so no sum grows)."""

    def __init__(self, T: float, alpha: float):
        self.T, self.alpha = T, alpha
        self.x1 = self.y = 0.0

    def step(self, x: float) -> float:
        self.y = self.alpha * (self.y + 0.5 * self.T * (x + self.x1))
        self.x1 = x
        return self.y


class Channel:
    """One accelerometer: step(a) -> (filtered a, velocity, displacement)."""

    def __init__(self, T: float, f_hp: float, f_lp: float, f_post: float, filtered: bool = True):
        self.filters: list[_HighPass | _Section] = [
            _HighPass(f_hp, T),
            _Section(butter2(f_lp, T, False)),
        ]
        self.filtered = filtered
        alpha = post_alpha(f_post, T)
        self.vel, self.pos = _Integrator(T, alpha), _Integrator(T, alpha)

    def step(self, a: float) -> tuple[float, float, float]:
        if self.filtered:
            for f in self.filters:
                a = f.step(a)
        v = self.vel.step(a)
        return a, v, self.pos.step(v)


def band_limit(x: np.ndarray, T: float, f_hp: float, f_lp: float, f_post: float) -> np.ndarray:
    """A displacement-like signal through the chain's transfer (band-pass and both post
    high-passes; the trapezoids are exact enough in band): the truth the estimates can see."""
    hp, lp = _HighPass(f_hp, T), _Section(butter2(f_lp, T, False))
    alpha = post_alpha(f_post, T)
    out = np.empty(len(x))
    y1 = y2 = p1 = p2 = 0.0
    for k, v in enumerate(x):
        b = lp.step(hp.step(float(v)))
        y1n = alpha * (y1 + b - p1)
        y2 = alpha * (y2 + y1n - p2)
        p1, p2, y1 = b, y1n, y1n
        out[k] = y2
    return out


def params() -> tuple[Param, ...]:
    """The chain's settings as estimator parameters."""
    return (
        Param("f_hp", "Hz", q=24, default=0.5, lo=0.01, hi=10, doc="band-pass low corner"),
        Param("f_lp", "Hz", q=24, default=20.0, lo=1, hi=45, doc="band-pass high corner"),
        Param("f_post", "Hz", q=24, default=0.1, lo=0, hi=5, doc="post-integration HP, 0 off"),
    )
