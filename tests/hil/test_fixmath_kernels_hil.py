"""fixmath's assembly kernels and the estimator steps written in assembly against their C
twins, through the estimators that call them, on the chip and in the native build, answer
for answer, fed inputs past every range (the shipped drives never leave the physical one):
MANF FIXED on wheel speeds; ESO FIXED (eso_avr.S with accel_cond_avr.S: the conditioning
channels and the observers, and for variant A the road, the controller's call and the
outputs) on accelerations, on configurations that take each factor's shift and sign through
its range (T, the corners, the post high-pass off, the 1 kHz retune, variant B with the
controller on, variant A with it on)."""

import struct

import numpy as np
import pytest

from vehil.boards import BoardOptions, open_board
from vehil.estimators import eso, manf
from vehil.estimators.base import EstimatorSpec

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


def _answers(
    board: str, spec: EstimatorSpec, params: dict[str, float], inputs: list[bytes]
) -> list[tuple]:
    with open_board(board, BoardOptions(timeout_s=5.0)) as link:
        link.configure(spec.name, "FIXED", spec.encode_params(spec.param_values(params), "FIXED"))
        replies = link.pipeline(("SAMPLE", {"inputs": x}) for x in inputs)
        return [(r.fields()["status"], r.fields()["outputs"]) for r in replies]


@pytest.mark.parametrize(
    "params",
    [
        {"r_w": 0.31, "T": 0.001},  # R ω a 32 × 24 product
        # R ω a shift; γ = 1.9 per sample (t_ref = 0), the top of FIXED's range for R_g γ
        {"r_w": 1.0, "T": 0.1, "gamma": 1.9, "xi": 0.5, "a": 100.0, "rg0": 100.0, "t_ref": 0.0},
        {"r_w": 0.1, "T": 2e-4, "gamma": 1.0001, "xi": 1e-9, "reading": 1.0},
    ],
)
def test_manf_fixed_gives_the_native_builds_bits_past_every_range(built, params) -> None:  # noqa: ANN001
    inputs = _wheel_speeds(seed=len(params))
    chip = _answers("simavr", manf.SPEC, params, inputs)
    host = _answers("native", manf.SPEC, params, inputs)
    assert chip == host
    assert any(status & 1 for status, _ in chip)  # SATURATED came up, and went again
    assert chip[-1] != chip[0]


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


@pytest.mark.parametrize(
    "params",
    [
        {"active": 0},  # the shipped passive drive's configuration
        {"T": 0.001, "eps": 0.003, "design": 1, "road_from": 1, "active": 0},  # the retune
        {"T": 2e-4, "eps": 2.0, "f_hp": 0.02, "f_post": 0.0, "active": 0},  # tiny factors
        {"T": 0.05, "eps": 0.5, "f_hp": 4.4, "f_lp": 9.0, "f_post": 5.0, "variant": 1},  # c12 0.99
        {"active": 1},  # variant A with the controller: the assembly's whole step
    ],
)
def test_eso_fixed_gives_the_native_builds_bits_past_every_range(built, params) -> None:  # noqa: ANN001
    inputs = _accelerations(seed=len(params))
    chip = _answers("simavr", eso.SPEC, params, inputs)
    host = _answers("native", eso.SPEC, params, inputs)
    assert chip == host
    assert any(status & 1 for status, _ in chip)  # SATURATED came up
