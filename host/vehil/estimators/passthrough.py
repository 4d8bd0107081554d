"""The built-in passthrough (C id 0): returns its input. It exercises the link,
the runner, the recorder and the report before any real estimator exists."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from vehil.estimators import register
from vehil.estimators.base import EstimatorSpec, Signal


class _Identity:
    def step(self, u: np.ndarray) -> np.ndarray:
        return np.array(u, dtype=np.float64)


def _reference(params: Mapping[str, float]) -> _Identity:
    return _Identity()


SPEC = register(
    EstimatorSpec(
        name="passthrough",
        c_id=0,
        title="Passthrough: output = input",
        inputs=(Signal("y", "1", q=24, doc="measured signal"),),
        outputs=(Signal("y", "1", q=24, doc="the same signal, back from the board"),),
        reference=_reference,
    )
)
