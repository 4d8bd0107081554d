"""A plant that streams its drive gives, chunk by chunk, the very drive it gives whole:
every signal and truth bit for bit, whatever the chunk size (so a long run can be made
in chunks without changing a single sample of a shipped scenario)."""

from __future__ import annotations

import numpy as np
import pytest

from vehil import plants
from vehil.plants.base import join

CASES = [
    ("acc_drive", {}, 6.0, 0.01),
    ("acc_drive", {"profile": 2, "drift": 0.05}, 6.0, 0.001),
    ("longitudinal", {}, 4.0, 0.01),  # the GPS road
    ("longitudinal", {"road": 0, "resample": 1, "dither": 0.05, "noise": 1}, 4.0, 0.01),
    ("longitudinal", {"road": 2, "profile": 1, "mass_step": 300, "t_mass": 1.0}, 4.0, 0.02),
    ("quarter_car", {"road": 2}, 1.0, 0.01),  # ISO road: drawn as it goes
    ("quarter_car", {"road": 3, "patch_len": 0.2, "acc_bw": 20.0}, 1.0, 0.001),
    ("ev4wd", {"noise": 1.0}, 0.5, 0.01),
    ("ev4wd", {"manoeuvre": 1, "sigma_x": 0.3}, 0.5, 0.005),
    ("noisy_sine", {}, 3.0, 0.01),
]


@pytest.mark.parametrize(("name", "params", "duration", "T"), CASES)
@pytest.mark.parametrize("chunk", [1, 7, 256])
def test_a_drive_in_chunks_is_the_drive_made_whole(name, params, duration, T, chunk) -> None:  # noqa: ANN001
    plant = plants.get(name)
    whole = plant.run(params, duration, T, seed=3)
    pieces = list(plant.run_chunks(params, duration, T, 3, chunk))
    assert max(len(p) for p in pieces) <= chunk
    joined = join(pieces)
    assert np.array_equal(joined.t, whole.t)
    for got, want in ((joined.signals, whole.signals), (joined.truth, whole.truth)):
        assert got.keys() == want.keys()
        for k in want:
            assert np.array_equal(got[k], want[k]), f"{name}: {k} differs"


def test_every_plant_that_can_stream_is_checked_here() -> None:
    streaming = {n for n, p in plants.plants().items() if p.stream is not None}
    assert streaming == {name for name, *_ in CASES}
