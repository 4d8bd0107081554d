"""What an estimator tells the host: its signals, parameters, numeric formats and reference.

An estimator exists three times: a float64 reference (Python, here), float32 C and
fixed-point C (firmware/lib/estimators, one source for the board and the native
build). Its EstimatorSpec ties them together: the runner, the recorder and the
report know estimators only through it.

On the wire every value is 4 bytes in the configured mode's format: float32, or
int32 with `q` fractional bits (Q(31-q).q) for that signal in FIXED mode.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from vehil.spec import INT32_RANGE, Param, Signal, resolve_params

MODES = ("F32", "FIXED")
# A rule over several parameters that the C's configure enforces too: given the values and
# the numeric mode, what is wrong with them, or None. Its docstring states it in one line
# (`vehil estimators NAME` lists it).
Rule = Callable[[Mapping[str, float], str], str | None]


def t_ref_param(doc: str, default: float = 0.0) -> Param:
    """`t_ref`: 0, the estimator's rates act per sample; > 0, they are rates per t_ref
    seconds of time, raised to T / t_ref a step, so the filter is the same at any T."""
    return Param("t_ref", "s", q=30, default=default, lo=0.0, hi=1.0, doc=doc)


class Reference(Protocol):
    """The float64 reference: the same step the board runs, in double precision."""

    def step(self, u: np.ndarray) -> np.ndarray: ...


def encode_values(
    values: Sequence[float] | np.ndarray, signals: Sequence[Signal], mode: str
) -> bytes:
    """Values in the mode's wire format; FIXED rounds to nearest and saturates."""
    x = np.asarray(values, dtype=np.float64)
    if mode == "F32":
        return x.astype("<f4").tobytes()
    q = np.array([s.q for s in signals], dtype=np.float64)
    scaled = np.rint(x * np.exp2(q))
    return np.clip(scaled, *INT32_RANGE).astype("<i4").tobytes()


def decode_values(data: bytes, signals: Sequence[Signal], mode: str) -> np.ndarray:
    if mode == "F32":
        return np.frombuffer(data, dtype="<f4").astype(np.float64)
    q = np.array([s.q for s in signals], dtype=np.float64)
    return np.frombuffer(data, dtype="<i4").astype(np.float64) * np.exp2(-q)


@dataclass(frozen=True)
class EstimatorSpec:
    """An estimator as the host sees it. `name` is also the C descriptor's name."""

    name: str
    c_id: int
    title: str
    inputs: tuple[Signal, ...]
    outputs: tuple[Signal, ...]
    reference: Callable[[Mapping[str, float]], Reference]
    params: tuple[Param, ...] = ()
    modes: tuple[str, ...] = MODES
    paper: str = ""  # the seed note it follows, e.g. "004-acc-speed-kalman-patent"
    delay: int = 0  # samples: output k estimates the truth at sample k - delay
    doc: str = ""
    # Optional hooks by name. "in_band": (truth, params) -> that truth as the estimates can
    # see it (a band-limited one); `vehil sweep` scores the outputs in metres against it too.
    extra: dict[str, object] = field(default_factory=dict)
    # Cycles per step the estimator must keep on the ATmega2560, by mode: the median over
    # its scenario, stop-and-wait (`vehil profile --budgets` checks them).
    budget: Mapping[str, int] = field(default_factory=dict)
    # The shipped scenario its cycles are measured on: the costliest case it ships (every
    # option on); "" for the first shipped one that runs it.
    budget_scenario: str = ""
    # Checks beyond each parameter's range, the C's as well (vehil build probes both).
    rules: tuple[Rule, ...] = ()

    def param_values(self, given: Mapping[str, float]) -> dict[str, float]:
        """Defaults overridden by `given`; raises ValueError naming each bad one."""
        return resolve_params(self.name, self.params, given)

    def rule_problems(self, values: Mapping[str, float], mode: str) -> list[str]:
        """What the spec's rules refuse in these values in this mode (the board would too)."""
        return [m for rule in self.rules if (m := rule(values, mode))]

    def encode_params(self, values: Mapping[str, float], mode: str) -> bytes:
        return encode_values([values[p.name] for p in self.params], self.params, mode)

    def encode_inputs(self, u: Sequence[float] | np.ndarray, mode: str) -> bytes:
        return encode_values(u, self.inputs, mode)

    def decode_outputs(self, data: bytes, mode: str) -> np.ndarray:
        return decode_values(data, self.outputs, mode)

    def quantise_inputs(self, u: np.ndarray, mode: str) -> np.ndarray:
        """The inputs exactly as the board sees them (for a reference fed the same bits)."""
        return decode_values(encode_values(u, self.inputs, mode), self.inputs, mode)
