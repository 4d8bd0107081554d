"""STLQF and RLS in C (float32) against their float64 references (seed 002)."""

import pytest

from vehil.boards import open_board
from vehil.errors import BoardError
from vehil.estimators import stlqf


@pytest.mark.parametrize(
    ("name", "output", "limit"),
    [
        ("paper-dither", "m", 0.05),
        ("mass-step", "m", 2.0),
        ("rls-flat-steps", "grade", 0.5),
        ("rls-flat-steps-fixed", "grade", 6.0),
    ],
)
def test_c_follows_the_reference(run_scenario, name, output, limit) -> None:  # noqa: ANN001
    result = run_scenario(name, board="native", duration=45.0)
    result.assert_passed()
    assert result.figures["outputs"][output]["reference"]["max_abs"] < limit


def test_a_weight_matrix_that_is_not_positive_definite_is_refused_with_a11(built) -> None:  # noqa: ANN001
    spec = stlqf.STLQF
    values = spec.param_values({"a11": 1.0, "a12": 3.0})
    with open_board("native") as link, pytest.raises(BoardError, match="BAD_PARAM") as exc:
        link.configure("stlqf", "F32", spec.encode_params(values, "F32"))
    assert exc.value.detail == [p.name for p in spec.params].index("a11")


def test_the_prefilter_in_c_follows_the_reference(run_scenario) -> None:  # noqa: ANN001
    result = run_scenario("noisy-prefilter", board="native", duration=20.0)
    assert result.figures["outputs"]["m"]["reference"]["rmse"] < 5.0


def test_fixed_point_rls_refuses_a_prefilter_naming_it(built) -> None:  # noqa: ANN001
    spec = stlqf.RLS
    values = spec.param_values({"prefilter_hz": 1.0})
    with open_board("native") as link, pytest.raises(BoardError, match="BAD_PARAM") as exc:
        link.configure("rls", "FIXED", spec.encode_params(values, "FIXED"))
    assert exc.value.detail == [p.name for p in spec.params].index("prefilter_hz")
