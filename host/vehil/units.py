"""Units of logged signals, through pint: spellings loggers use, and conversion.

A logger writes `km/h`, `kph`, `Meters/second`, `g`, `°` or `m/s²`; an estimator wants
`m/s`, `m/s^2` or `rad/s`. `convert` turns a column into the unit an estimator input
wants, or says why it cannot. In a vehicle log `g` is the standard gravity, never a gram.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

# Spellings pint does not read as a logger means them (lower-cased keys).
_ALIASES = {
    "g": "g_n",
    "kmh": "km/h",
    "km/hr": "km/h",
    "meters/second": "m/s",
    "meters per second": "m/s",
    "m/s2": "m/s^2",
    "m/s/s": "m/s^2",
    "rad/s2": "rad/s^2",
    "nm": "N*m",
    "n.m": "N*m",
    "-": "1",
    "deg/sec": "deg/s",
    "rev/min": "rpm",
    "sec": "s",
    "secs": "s",
    "msec": "ms",
}


class UnitError(ValueError):
    """A unit string pint cannot read, or two units that do not convert."""


@functools.cache
def _registry() -> Any:
    import pint  # imported here: only logs need it

    return pint.UnitRegistry()


def parse(text: str) -> Any:
    """The pint unit of a logger's spelling; UnitError if none reads."""
    ureg = _registry()
    spelled = text.strip()
    for candidate in (spelled, _ALIASES.get(spelled.lower()), spelled.lower()):
        if not candidate:
            continue
        try:
            return ureg.Unit(_ALIASES.get(candidate.lower(), candidate))
        except Exception:  # pint raises several types for a bad spelling
            continue
    raise UnitError(f"unknown unit {text!r}")


def known(text: str) -> bool:
    try:
        parse(text)
    except UnitError:
        return False
    return True


def convert(x: np.ndarray, have: str, want: str, per: str = "") -> np.ndarray:
    """x in unit `have` (divided by unit `per`: a derivative, a speed over a radius) as
    unit `want`. Each spelling is read on its own, so `g` stays a gravity in `g/s`."""
    ureg = _registry()
    unit = parse(have) / parse(per) if per else parse(have)
    try:
        return np.asarray(ureg.Quantity(x, unit).to(parse(want)).magnitude, dtype=float)
    except UnitError:
        raise
    except Exception as exc:  # pint's DimensionalityError
        raise UnitError(f"{have!r} does not convert to {want!r} ({exc})") from None


def same(have: str, want: str, per: str = "") -> bool:
    """True if the two spellings are one unit (no conversion is applied)."""
    return (parse(have) / parse(per) if per else parse(have)) == parse(want)
