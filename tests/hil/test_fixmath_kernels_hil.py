"""fixmath's assembly kernels against their C twins, through an estimator that calls them:
MANF FIXED on the chip and in the native build, fed wheel speeds past every range (the
shipped drives never leave the physical one), answer for answer."""

import struct

import numpy as np
import pytest

from vehil.boards import BoardOptions, open_board
from vehil.estimators import manf

pytestmark = pytest.mark.hil

I32 = (-(2**31), 2**31 - 1)


def _wheel_speeds(seed: int) -> list[bytes]:
    """Raw Q16 pairs: the int32 edges, speeds that saturate R ω either way, then a braking
    ramp with noise (the gain grows and shrinks on it) and random int32s."""
    rng = np.random.default_rng(seed)
    edges = [0, 1, -1, *I32, I32[0] + 1, 2**23, -(2**23), 2**27, -(2**27), 2**24 + 2**15]
    ramp = (90.0 - 0.05 * np.arange(300)) + rng.normal(0, 0.3, 300)
    wild = rng.integers(*I32, 100, endpoint=True)
    values = edges + [int(round(w * 2**16)) for w in ramp] + [int(w) for w in wild] + edges
    return [struct.pack("<ii", w, w // 3) for w in values]


def _answers(board: str, params: dict[str, float], inputs: list[bytes]) -> list[tuple]:
    spec = manf.SPEC
    with open_board(board, BoardOptions(timeout_s=5.0)) as link:
        link.configure("manf", "FIXED", spec.encode_params(spec.param_values(params), "FIXED"))
        replies = link.pipeline(("SAMPLE", {"inputs": x}) for x in inputs)
        return [(r.fields()["status"], r.fields()["outputs"]) for r in replies]


@pytest.mark.parametrize(
    "params",
    [
        {"r_w": 0.31, "T": 0.001},  # R ω a 32 × 24 product
        {"r_w": 1.0, "T": 0.1, "gamma": 1.9, "xi": 0.5, "a": 100.0, "rg0": 100.0},  # a shift
        {"r_w": 0.1, "T": 2e-4, "gamma": 1.0001, "xi": 1e-9, "reading": 1.0},
    ],
)
def test_manf_fixed_gives_the_native_builds_bits_past_every_range(built, params) -> None:  # noqa: ANN001
    inputs = _wheel_speeds(seed=len(params))
    chip = _answers("simavr", params, inputs)
    host = _answers("native", params, inputs)
    assert chip == host
    assert any(status & 1 for status, _ in chip)  # SATURATED came up, and went again
    assert chip[-1] != chip[0]
