"""Estimators that keep state: a NaN input is flagged and leaves the state as it was."""

import numpy as np
import pytest

from vehil.boards import open_board
from vehil.estimators import acc_kf, eso, kfui, stlqf, upf


@pytest.mark.parametrize(
    ("spec", "good", "bad"),
    [
        (acc_kf.SPEC, [0.1, 60.0, 60.0, 0.0], [float("nan"), 60.0, 60.0, 0.0]),
        (eso.SPEC, [0.3, -2.0], [float("nan"), 0.0]),
        (kfui.SPEC, [0.3, -2.0], [float("nan"), 0.0]),
        (stlqf.STLQF, [20.0, 0.5, 2000.0], [20.0, float("nan"), 2000.0]),
        (stlqf.RLS, [20.0, 0.5, 2000.0], [20.0, float("nan"), 2000.0]),
        (upf.EKF, [0.0, 0.0, 0.0, *[74.0] * 4, 0.0, *[20.0] * 4], [float("nan"), *[0.0] * 11]),
        (upf.UKF, [0.0, 0.0, 0.0, *[74.0] * 4, 0.0, *[20.0] * 4], [*[0.0] * 11, float("nan")]),
    ],
    ids=lambda x: getattr(x, "name", ""),
)
def test_a_nan_input_is_flagged_and_leaves_the_state_alone(built, spec, good, bad) -> None:  # noqa: ANN001
    with open_board("native") as link:
        link.configure(spec.name, "F32", spec.encode_params(spec.param_values({}), "F32"))
        frames = [good, good, bad, good]
        replies = list(
            link.pipeline(("SAMPLE", {"inputs": spec.encode_inputs(u, "F32")}) for u in frames)
        )
    flags = [r.fields()["status"] for r in replies]
    assert flags[2] & 0x02 and not flags[1] & 0x02
    out = [spec.decode_outputs(r.fields()["outputs"], "F32") for r in replies]
    np.testing.assert_array_equal(out[2], out[1])
    assert np.all(np.isfinite(out[3]))
