"""The ESO's frequency response from the two accelerometers to each estimate, and what it
would take to be ideal (docs/estimators/eso.md, "Frequency response").

Measured on the float64 reference itself (passive, small impulses so the strut's nonlinear
terms vanish): an impulse on a_s, then one on a_us, through conditioning + observer; the
FFT of each response over the ideal transfer of the same quantity gives its gain and
phase error. Ideal, for a passive car: x = a/s², v = a/s, F = a, and the road from the
wheel's equation with the strut force from the body's, x_r = x_us + (m_us a_us +
m_s a_s)/k_us. The band-pass + double integration (BP+DI) column is the conditioning
chain alone (its displacement y, velocity and filtered acceleration, and that road).

    python -m vehil.eso_response [--set design=1 --set eps=0.01 ...] [--plot FILE]
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

from vehil.estimators import eso
from vehil.estimators._accel_conditioning import Channel
from vehil.models.quarter_car import nominal

N = 1 << 15
IMPULSE = 1e-6  # m/s² × sample: small enough that k2, k3, c2 terms are ~1e-12 of k1, c1
OUTPUTS = ("x_s", "v_s", "F1", "x_us", "v_us", "F2", "x_r")
COLUMNS = {"x_s": 0, "v_s": 1, "x_us": 2, "v_us": 3, "F1": 4, "F2": 5, "x_r": 6}
BAND = (0.5, 20.0)  # Hz
FREQS = (0.5, 1.0, 2.0, 5.0, 9.25, 15.0, 20.0)


def _impulse(step: Callable[[np.ndarray], np.ndarray], k_input: int, n: int) -> np.ndarray:
    out = []
    for k in range(n):
        a = np.zeros(2)
        if k == 0:
            a[k_input] = IMPULSE
        out.append(step(a))
    return np.array(out) / IMPULSE


def bpdi(p: Mapping[str, float]) -> Callable[[np.ndarray], np.ndarray]:
    """The conditioning alone as an estimator, a step with the ECU's first seven outputs: the
    displacements and velocities it integrates, its filtered accelerations as F̂, and
    x̂_r = y_us + (m_us a_us + m_s a_s)/k_us from them."""
    ch = [Channel(p["T"], p["f_hp"], p["f_lp"], p["f_post"]) for _ in range(2)]
    m = nominal(p)

    def step(a: np.ndarray) -> np.ndarray:
        (af_s, v_s, y_s), (af_us, v_us, y_us) = (
            c.step(float(x)) for c, x in zip(ch, a, strict=True)
        )
        x_r = y_us + (m.m_us * af_us + m.m_s * af_s) / m.k_us
        return np.array([y_s, v_s, y_us, v_us, af_s, af_us, x_r])

    return step


def responses(p: Mapping[str, float], n: int = N) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(f, {"ESO x_r/a_us": H(f), ...}) for the estimator with parameters p and for BP+DI."""
    T = p["T"]
    f = np.fft.rfftfreq(n, T)
    out: dict[str, np.ndarray] = {}
    for name, make in (("ESO", lambda: eso.ecu(p).step), ("BP+DI", lambda: bpdi(p))):
        for k_in, src in enumerate(("a_s", "a_us")):
            h = np.fft.rfft(_impulse(make(), k_in, n), axis=0)
            for o in OUTPUTS:
                out[f"{name} {o}/{src}"] = h[:, COLUMNS[o]]
    return f, out


def ideal(p: Mapping[str, float], f: np.ndarray) -> dict[str, np.ndarray]:
    """The exact transfers of a passive car, s = jω (the DC term left out)."""
    m = nominal(p)
    s = 2j * np.pi * np.where(f > 0, f, 1.0)  # DC: not used
    one = np.ones_like(s)
    return {
        "x_s/a_s": 1 / s**2,
        "v_s/a_s": 1 / s,
        "F1/a_s": one,
        "x_us/a_us": 1 / s**2,
        "v_us/a_us": 1 / s,
        "F2/a_us": one,
        "x_r/a_us": 1 / s**2 + m.m_us / m.k_us,
        "x_r/a_s": m.m_s / m.k_us * one,
    }


def over_ideal(
    p: Mapping[str, float], freqs: Sequence[float] = FREQS, n: int = N
) -> dict[str, np.ndarray]:
    """{"ESO x_s/a_s": H/H_ideal at each of `freqs`, ...} for the ESO and for BP+DI."""
    f, h = responses(p, n)
    ref = ideal(p, f)
    idx = [int(np.argmin(np.abs(f - fq))) for fq in freqs]
    return {
        f"{name} {key}": (h[f"{name} {key}"] / want)[idx]
        for key, want in ref.items()
        for name in ("ESO", "BP+DI")
    }


def table(p: Mapping[str, float], freqs: Sequence[float] = FREQS) -> list[tuple[str, list[str]]]:
    """Gain and phase (degrees) of each estimate over its ideal at `freqs`."""
    return [
        (name, [f"{abs(c):.2f} ∠{np.degrees(np.angle(c)):+.0f}°" for c in r])
        for name, r in over_ideal(p, freqs).items()
    ]


def plot(p: Mapping[str, float], path: Path, label: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    f, h = responses(p)
    ref = ideal(p, f)
    keys = ("x_s/a_s", "F1/a_s", "x_us/a_us", "F2/a_us", "x_r/a_us", "x_r/a_s")
    fig, axes = plt.subplots(2, len(keys), figsize=(3.2 * len(keys), 5.5), sharex=True)
    band = (f >= 0.2) & (f <= 45)
    for j, key in enumerate(keys):
        for name, style in (("ESO", "-"), ("BP+DI", "--")):
            r = h[f"{name} {key}"][band] / ref[key][band]
            axes[0, j].semilogx(f[band], np.abs(r), style, label=name)
            axes[1, j].semilogx(f[band], np.degrees(np.angle(r)), style)
        axes[0, j].set_title(key + " over ideal")
        axes[0, j].set_ylim(0, 2)
        axes[1, j].set_ylim(-180, 180)
        for ax in axes[:, j]:
            ax.axvspan(*BAND, color="0.92", zorder=0)
            ax.grid(True, which="both", lw=0.3)
        axes[1, j].set_xlabel("Hz")
    axes[0, 0].set_ylabel("gain")
    axes[1, 0].set_ylabel("phase (°)")
    axes[0, 0].legend()
    fig.suptitle(f"ESO ({label}) and band-pass + double integration, over the ideal transfer")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m vehil.eso_response", description=__doc__)
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--plot", type=Path)
    args = ap.parse_args(argv)
    given = dict(s.split("=", 1) for s in args.set)
    p = eso.SPEC.param_values({"active": 0, **{k: float(v) for k, v in given.items()}})
    label = ", ".join(args.set) or "the paper's: A, ε = 0.1"
    print(f"gain ∠phase of each estimate over the ideal, {label}")
    print(f"{'':24}" + "".join(f"{fq:>13g} Hz" for fq in FREQS))
    for name, cells in table(p):
        print(f"{name:24}" + "".join(f"{c:>16}" for c in cells))
    if args.plot:
        plot(p, args.plot, label)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
