"""Seed 001's EKF and UKF in C (float32) against their float64 references."""

import pytest

from vehil.boards import open_board
from vehil.errors import BoardError
from vehil.estimators import upf


@pytest.mark.parametrize(
    ("name", "duration"),
    [
        ("s1-dlc80-ekf", 20.0),
        ("s1-dlc80-ekf3", 20.0),
        ("s1-dlc80-ekf3-linear", 20.0),
        ("s1-dlc80-ukf", 20.0),
        ("s2-sine80-ekf", 10.0),
        ("s3-tcs-low-mu-ekf", 20.0),
        ("s4-abs-low-mu-ekf", 20.0),
        ("s5-dlc100-low-mu-ukf", 10.0),
        ("s6-sine100-low-mu-ukf", 10.0),
    ],
)
def test_c_follows_the_reference(run_scenario, name, duration) -> None:  # noqa: ANN001
    result = run_scenario(name, board="native", duration=duration)
    result.assert_passed()
    outputs = result.figures.outputs
    assert outputs["vx"].reference.max_abs < 2e-3
    assert max(outputs[f"fy{i}"].reference.max_abs for i in range(1, 5)) < 0.1


@pytest.mark.parametrize(
    ("spec", "name", "value"),
    [
        (upf.EKF, "mu", 2.0),
        (upf.EKF, "r_clip", 0.5),
        (upf.EKF3, "vx0", 0.1),
        (upf.UKF, "q_f", -1.0),
        (upf.UKF, "alpha", 0.0),
    ],
)
def test_a_bad_parameter_is_refused_with_its_index(built, spec, name, value) -> None:  # noqa: ANN001
    values = {**spec.param_values({}), name: value}  # past the host's own check
    with open_board("native") as link, pytest.raises(BoardError, match="BAD_PARAM") as exc:
        link.configure(spec.name, "F32", spec.encode_params(values, "F32"))
    assert exc.value.detail == [p.name for p in spec.params].index(name)
