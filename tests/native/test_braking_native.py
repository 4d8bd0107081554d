"""Seed 000's board estimators (MANF, UIIEKF) in the native build against their references."""

import pytest

from vehil.boards import open_board
from vehil.errors import BoardError
from vehil.estimators import uiiekf


@pytest.mark.parametrize(
    "name",
    [
        "manf-hard-stop",
        "manf-hard-stop-fixed",
        "manf-abs-snow",
        "uiiekf3-abs-dry",
        "uiiekf-wet-mismatch",
    ],
)
def test_board_estimators_follow_their_references(run_scenario, name) -> None:  # noqa: ANN001
    run_scenario(name, board="native").assert_passed()


def test_uiiekf_refuses_a_state_count_it_does_not_have(built) -> None:  # noqa: ANN001
    spec = uiiekf.SPEC
    values = spec.param_values({}) | {"n_states": 4.0}
    with open_board("native") as link, pytest.raises(BoardError, match="BAD_PARAM") as exc:
        link.configure("uiiekf", "F32", spec.encode_params(values, "F32"))
    assert exc.value.detail == [p.name for p in spec.params].index("n_states")
