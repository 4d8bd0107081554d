"""Seed 000's UIIEKF: the unknown input is decoupled and the filter beats MANF."""

import numpy as np
import pytest

from vehil import plants
from vehil.estimators import manf, uiiekf


def drive(T: float = 0.005, **params: float):  # noqa: ANN201
    trace = plants.get("braking").run({"profile": 2, "torque": 3000, **params}, 3.0, T, 1)
    return trace, np.column_stack([trace.signals["omega_f"], trace.signals["omega_r"]])


@pytest.mark.parametrize("n_states", [5, 3])
def test_the_unknown_input_is_decoupled_and_the_error_dynamics_are_stable(n_states) -> None:  # noqa: ANN001
    trace, u = drive()
    f = uiiekf.Uiiekf(uiiekf.SPEC.param_values({"n_states": n_states, "T": 0.005}))
    v = np.array([f.step(x)[0] for x in u])
    assert max(f.c1_norm) < 1e-12  # condition C1: (I - L C) B = 0
    radius = np.array([np.max(np.abs(e)) for e in f.eigenvalues])
    if n_states == 3:  # condition C2 holds along the run (Fig. 12)
        assert np.median(radius) < 1.0
    else:  # v_y and r are unobservable from wheel speeds in a straight line: neutral modes
        assert np.median(radius) < 1.01
    assert np.sqrt(np.mean((v - trace.truth["v"]) ** 2)) < 0.1


def test_uiiekf_is_more_accurate_than_manf_as_table_4_says() -> None:
    trace, u = drive()
    ui = uiiekf.Uiiekf(uiiekf.SPEC.param_values({"T": 0.005}))
    mf = manf.Manf(manf.SPEC.param_values({"T": 0.005}))
    v_ui = np.array([ui.step(x)[0] for x in u])
    v_mf = np.array([mf.step(x)[0] for x in u])
    mse_ui = np.mean((v_ui - trace.truth["v"]) ** 2)
    mse_mf = np.mean((v_mf - trace.truth["v"]) ** 2)
    assert mse_ui < mse_mf / 3


def test_the_printed_iteration_shrinks_p_faster_than_one_pass() -> None:
    _, u = drive()
    # A Q that leaves the updates visible after the time update (the default's q_w adds
    # more to the wheels each step than the four extra passes take off)
    small_q = {"T": 0.005, "q_v": 0.02, "q_w": 2.0}
    printed = uiiekf.Uiiekf(uiiekf.SPEC.param_values({"iterations": 5, **small_q}))
    once = uiiekf.Uiiekf(uiiekf.SPEC.param_values({"form": 1, **small_q}))
    for x in u[:50]:
        printed.step(x)
        once.step(x)
    seen = [0, -2, -1]  # v_x and the wheels (v_y and r are not seen in a straight line)
    assert np.all(np.diag(printed.P)[seen] < np.diag(once.P)[seen])  # z applied five times


def test_the_five_state_filter_is_the_three_state_one_in_a_straight_line() -> None:
    """δ = 0 decouples v_y and r from the wheels exactly, so they never leave zero (the
    board's C relies on it: docs/estimators/uiiekf.md)."""
    _, u = drive()
    five = uiiekf.Uiiekf(uiiekf.SPEC.param_values({"T": 0.005}))
    three = uiiekf.Uiiekf(uiiekf.SPEC.param_values({"T": 0.005, "n_states": 3}))
    for x in u:
        v5, v3 = five.step(x)[0], three.step(x)[0]
        assert five.x is not None and five.x[1] == 0.0 and five.x[2] == 0.0
        assert abs(v5 - v3) < 1e-9
    assert np.all(five.P[1:3, [0, 3, 4]] == 0.0)
