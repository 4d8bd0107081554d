"""Seed 000's board estimators (MANF, UIIEKF) in the native build against their references."""

import numpy as np
import pytest

from vehil.boards import open_board
from vehil.errors import BoardError
from vehil.estimators import manf, uiiekf
from vehil.protocol.schema import SCHEMA

DIVERGED = SCHEMA.status["DIVERGED"]


@pytest.mark.parametrize(
    "name",
    [
        "manf-hard-stop",
        "manf-hard-stop-fixed",
        "manf-abs-snow",
        "manf-hard-stop-10ms-rate",
        "manf-hard-stop-10ms-rate-fixed",
        "manf-heavy-hifi-fixed",  # unlike the shipped drives: 2.6 t on the hi-fi plant
        "anf-hard-stop",
        "anf-abs-snow-fixed",
        "uiiekf3-abs-dry",
        "uiiekf-wet-mismatch",
        "uiiekf3-other-car",
    ],
)
def test_board_estimators_follow_their_references(run_scenario, name) -> None:  # noqa: ANN001
    run_scenario(name, board="native").assert_passed()


@pytest.mark.parametrize("mode", ["F32", "FIXED"])
def test_manf_refuses_a_rate_past_its_per_sample_ceiling(built, mode: str) -> None:  # noqa: ANN001
    """γ = 1.01 per millisecond is γ^100 = 2.7 per 100 ms step, past 1.9: BAD_PARAM t_ref."""
    spec = manf.SPEC
    values = spec.param_values({"T": 0.1, "t_ref": 0.001})
    with open_board("native") as link, pytest.raises(BoardError, match="BAD_PARAM") as exc:
        link.configure("manf", mode, spec.encode_params(values, mode))
    assert exc.value.detail == [p.name for p in spec.params].index("t_ref")


def test_uiiekf_refuses_a_state_count_it_does_not_have(built) -> None:  # noqa: ANN001
    spec = uiiekf.SPEC
    values = spec.param_values({}) | {"n_states": 4.0}
    with open_board("native") as link, pytest.raises(BoardError, match="BAD_PARAM") as exc:
        link.configure("uiiekf", "F32", spec.encode_params(values, "F32"))
    assert exc.value.detail == [p.name for p in spec.params].index("n_states")


def test_the_uiiekf_flags_a_car_whose_constants_it_was_not_given(run_scenario) -> None:  # noqa: ANN001
    """The same drive of another car: told its values, the filter holds 0.15 m/s and stays
    healthy; with the Pride's it is metres per second off and says so where the
    reference does."""
    told = run_scenario("uiiekf3-other-car", board="native")
    told.assert_passed()
    assert told.figures.status["DIVERGED"] == 0
    wrong = run_scenario("uiiekf3-other-car-pride-model", board="native")
    wrong.assert_passed()
    assert wrong.figures.outputs["v"].truth.rmse > 1.0
    flagged = (wrong.run.status & DIVERGED) != 0
    reference = uiiekf.Uiiekf(wrong.run.prepared.scenario.params)
    for u in wrong.run.prepared.inputs:
        reference.step(u)
    assert flagged.mean() > 0.5
    assert np.mean(flagged == np.array(reference.diverged)) > 0.99


def test_the_uiiekf_says_where_standing_leaves_its_estimates_undetermined(run_scenario) -> None:  # noqa: ANN001, E501
    """Standing, d̂ is the wheels' noise amplified and v̂ the model's: ILL_CONDITIONED on
    exactly the steps where both wheels turn slower than v_min, and on no moving step."""
    result = run_scenario("uiiekf3-stop-and-stand", board="native")
    result.assert_passed()
    flagged = (result.run.status & SCHEMA.status["ILL_CONDITIONED"]) != 0
    reference = uiiekf.Uiiekf(result.run.prepared.scenario.params)
    for u in result.run.prepared.inputs:
        reference.step(u)
    assert 200 < flagged.sum() < 500
    assert np.array_equal(flagged, np.array(reference.standstill))
    moving = result.run.prepared.truth()["v"] > 1.5
    assert not flagged[moving].any()
    assert result.figures.status["DIVERGED"] == 0


def test_the_uiiekf_flags_a_dead_sensor_and_wheels_read_backwards(built) -> None:  # noqa: ANN001
    spec = uiiekf.SPEC
    dead = [[92.6, 92.6]] * 50 + [[92.6 - 0.1 * k, 0.0] for k in range(100)]  # rear reads 0
    backwards = [[-50.0, -50.0]] * 10  # v̂(0) = R ω_f(0) = -13.5 m/s; wheels turning backwards
    for n_states in (3, 5):
        for frames, why in ((dead, "innovations"), (backwards, "speed")):
            with open_board("native") as link:
                values = spec.param_values({"n_states": n_states})
                link.configure("uiiekf", "F32", spec.encode_params(values, "F32"))
                requests = (("SAMPLE", {"inputs": spec.encode_inputs(u, "F32")}) for u in frames)
                status = [r.fields()["status"] for r in link.pipeline(requests)]
            flagged = [bool(s & DIVERGED) for s in status]
            if why == "innovations":  # healthy while the wheels agree, flagged once one dies
                assert not any(flagged[:50]) and all(flagged[55:]), (n_states, flagged)
            else:  # a speed below zero at once, then the wheels' below zero
                assert flagged[0] and all(flagged[5:]), (n_states, flagged)
