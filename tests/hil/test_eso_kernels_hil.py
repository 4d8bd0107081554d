"""The ESO step's assembly routines (the conditioning channel, accel_cond_avr.S, and the
observer, eso_avr.S) against their C twins, through the estimator that calls them: ESO FIXED
on the chip and in the native build, fed accelerations past every range (the shipped drives
stay inside them), answer for answer, on configurations that take each factor's shift and
sign through its range (T, the corners, the post high-pass off, the 1 kHz retune, variant B
with the controller on)."""

import struct

import numpy as np
import pytest

from vehil.boards import BoardOptions, open_board
from vehil.estimators import eso

pytestmark = pytest.mark.hil

I32 = (-(2**31), 2**31 - 1)


def _accelerations(seed: int) -> list[bytes]:
    """Raw Q16 pairs: the int32 edges (each saturates the conditioning's second difference
    and its rescale), a bumpy drive that stays in range, steps past the high-pass's range
    and back, and random int32s; the edges again, then a quiet stretch."""
    rng = np.random.default_rng(seed)
    edges = [0, 1, -1, *I32, I32[0] + 1, 2**26, -(2**26), 2**26 - 1, 2**25, -(2**25) - 1]
    t = np.arange(300) * 0.01
    drive = 30.0 * np.sin(2 * np.pi * 9.0 * t) + rng.normal(0, 1.0, t.size)
    steps = [1500.0, -1500.0, 20000.0, -20000.0, 0.0]
    wild = rng.integers(*I32, 100, endpoint=True)
    quiet = rng.normal(0, 0.1, 200)
    values = (
        edges
        + [int(round(a * 2**16)) for a in drive]
        + [int(round(a * 2**16)) for a in steps]
        + [int(w) for w in wild]
        + edges
        + [int(round(a * 2**16)) for a in quiet]
    )
    return [struct.pack("<ii", a, -a // 3) for a in values]


def _answers(board: str, params: dict[str, float], inputs: list[bytes]) -> list[tuple]:
    spec = eso.SPEC
    with open_board(board, BoardOptions(timeout_s=5.0)) as link:
        link.configure("eso", "FIXED", spec.encode_params(spec.param_values(params), "FIXED"))
        replies = link.pipeline(("SAMPLE", {"inputs": x}) for x in inputs)
        return [(r.fields()["status"], r.fields()["outputs"]) for r in replies]


@pytest.mark.parametrize(
    "params",
    [
        {"active": 0},  # the shipped passive drive's configuration
        {"T": 0.001, "eps": 0.003, "design": 1, "road_from": 1, "active": 0},  # the retune
        {"T": 2e-4, "eps": 2.0, "f_hp": 0.02, "f_post": 0.0, "active": 0},  # tiny factors
        {"T": 0.05, "eps": 0.5, "f_hp": 10.0, "f_lp": 9.0, "f_post": 5.0, "variant": 1},
    ],
)
def test_eso_fixed_gives_the_native_builds_bits_past_every_range(built, params) -> None:  # noqa: ANN001
    inputs = _accelerations(seed=len(params))
    chip = _answers("simavr", params, inputs)
    host = _answers("native", params, inputs)
    assert chip == host
    assert any(status & 1 for status, _ in chip)  # SATURATED came up
