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
        ("s1-dlc80-ekf3-suv", 20.0),
        ("s1-dlc80-ekf-suv", 10.0),
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
        (upf.EKF3, "m", 100.0),
        (upf.EKF, "c_yk", 1.2),
        (upf.UKF, "tau_wdot", 0.0),
    ],
)
def test_a_bad_parameter_is_refused_with_its_index(built, spec, name, value) -> None:  # noqa: ANN001
    values = {**spec.param_values({}), name: value}  # past the host's own check
    with open_board("native") as link, pytest.raises(BoardError, match="BAD_PARAM") as exc:
        link.configure(spec.name, "F32", spec.encode_params(values, "F32"))
    assert exc.value.detail == [p.name for p in spec.params].index(name)


def test_the_filter_given_the_car_holds_where_the_shipped_car_does_not(run_scenario) -> None:  # noqa: ANN001, E501
    """The same SUV lane change: the reduced EKF given the SUV's constants tracks it as it
    tracks the shipped car on that car's drive; left on the shipped car it is far off."""
    told = run_scenario("s1-dlc80-ekf3-suv", board="native")
    told.assert_passed()
    wrong = run_scenario("s1-dlc80-ekf3-suv-mismatch", board="native")
    wrong.assert_passed()  # the port still follows its reference

    def rms(result, name: str) -> float:  # noqa: ANN001
        return result.figures.outputs[name].truth.rmse

    fy = [f"fy{i}" for i in range(1, 5)]
    assert rms(told, "vx") < 0.05 and max(rms(told, n) for n in fy) < 60.0
    assert rms(wrong, "vx") > 20 * rms(told, "vx")
    assert min(rms(wrong, n) for n in fy) > 4 * max(rms(told, n) for n in fy)
    assert rms(wrong, "beta") > 2 * rms(told, "beta")
