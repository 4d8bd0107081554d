"""Seed 003's references: conditioning, ESO (A, B, no updating), KF-UI and the controller."""

import dataclasses

import numpy as np
import pytest
from scipy import signal

from vehil import plants
from vehil.estimators import eso, kfui
from vehil.estimators._accel_conditioning import Channel, _HighPass
from vehil.estimators._suspension_control import PredictiveController
from vehil.models.quarter_car import NOMINAL
from vehil.papers import eso as paper


def error_matrix(eps: float) -> np.ndarray:
    b = eso.gains(eps)
    return np.array([[-b[0], 1, 0], [-b[1], 0, 1], [-b[2], 0, 0]])


@pytest.mark.parametrize("eps", [0.05, 0.1, 0.5])
def test_the_eso_error_poles_are_minus_one_over_eps(eps: float) -> None:
    np.testing.assert_allclose(np.linalg.eigvals(error_matrix(eps)), -1 / eps, rtol=1e-4)


def test_the_steady_error_for_a_constant_h_is_remark_2s() -> None:
    eps, H = 0.1, 2.0
    z = np.linalg.solve(error_matrix(eps), -np.array([0, 0, 1.0]) * H)
    np.testing.assert_allclose(np.abs(z), [eps**3 * H, 3 * eps**2 * H, 3 * eps * H], rtol=1e-9)


@pytest.mark.parametrize(("T", "eps"), [(0.01, 0.1), (0.01, 0.004), (0.001, 0.003)])
def test_design_1_puts_the_euler_loops_poles_at_exp_minus_t_over_eps(T: float, eps: float) -> None:
    """The board's step is z += T ż with the measurement's error through T β: its error
    dynamics are [[1 - Tβ1, T, 0], [-Tβ2, 1, T], [-Tβ3, 0, 1]]. Design 1's gains give it the
    characteristic polynomial (λ - e^{-T/ε})³; the paper's only approach it for T << ε."""
    want = np.poly([np.exp(-T / eps)] * 3)
    for design, close in ((1, True), (0, T / eps < 0.2)):
        g = T * eso.gains(eps, T, design)
        loop = np.array([[1 - g[0], T, 0], [-g[1], 1, T], [-g[2], 0, 1]])
        got = np.poly(loop)
        assert np.allclose(got, want, atol=1e-9 if design else 0.05) == close


def test_road_from_the_body_needs_no_strut_model() -> None:
    """Fed with a passive car's own accelerations and displacements (no conditioning in the
    way: the observer's states set to the truth), x̂_r from -m_s F̂1 is exact whatever the
    strut, where the strut model's reading carries its friction as an error."""
    car = dataclasses.replace(NOMINAL, friction=200.0)
    x = np.array([0.01, 0.3, -0.004, -0.2])
    x_r = 0.002
    a_s, a_us = car.accelerations(x, 0.0, x_r)
    for road_from, exact in ((1, True), (0, False)):
        obs = eso.Eso(eso.SPEC.param_values({"road_from": road_from}))
        obs.z = np.array([x[0], x[1], a_s, x[2], x[3], a_us])
        got = obs.estimates()[3]
        assert (abs(got - x_r) < 1e-12) == exact


def test_the_delta_form_high_pass_is_scipys_butterworth() -> None:
    b, a = signal.butter(2, 0.5, "high", fs=100)
    x = np.random.default_rng(0).normal(size=3000)
    hp = _HighPass(0.5, 0.01)
    np.testing.assert_allclose([hp.step(v) for v in x], signal.lfilter(b, a, x), atol=1e-9)


def test_the_band_pass_removes_the_bias_the_raw_integration_keeps() -> None:
    figures = paper.integration_check()
    assert figures["unfiltered |x| at the end (m)"] > 1.0
    assert figures["band-passed correlation with the in-band truth"] > 0.9
    assert Channel(0.01, 0.5, 20, 0.1).step(0.035)[2] < 1e-6


def test_model_updating_beats_no_updating_on_the_wheel_and_the_road() -> None:
    errors = paper.observer_errors()
    with_, without = errors["ESO B (updating)"], errors["no updating"]
    for name in ("x_us", "v_us", "x_r"):
        assert with_[name] < 0.9 * without[name]


def test_variant_a_follows_a_1_hz_road_from_ideal_displacements() -> None:
    p = plants.get("quarter_car").param_values(
        {"road_freq": 1.0, "noise_var": 0.0, "bias_lo": 0.0, "bias_hi": 0.0}
    )
    trace = plants.get("quarter_car").run(p, 10.0, 0.01, 1)
    obs = eso.Eso(eso.SPEC.param_values({}))
    x_r = []
    for y_s, y_us in zip(trace.truth["x_s"], trace.truth["x_us"], strict=True):
        obs.step(y_s, y_us, 0.0)
        x_r.append(obs.estimates()[3])
    gain = np.std(x_r[500:]) / np.std(trace.truth["x_r"][500:])
    assert 0.7 < gain < 1.3


def test_the_controller_minimises_its_index() -> None:
    p = eso.SPEC.param_values({})
    ctrl = PredictiveController(NOMINAL, p)
    x, F1, F2, x_r = np.array([0.01, -0.1, 0.002, 0.3]), 1.5, -20.0, 0.004
    _, u = ctrl.law(x, F1, F2, x_r)
    for du in (-1.0, 1.0):
        assert ctrl.cost(u + du, x, F1, F2, x_r) > ctrl.cost(u, x, F1, F2, x_r)


def test_the_kfui_jacobian_matches_finite_differences() -> None:
    x = np.array([0.02, -0.3, -0.01, 0.5])
    J = NOMINAL.jacobian(x)
    h = 1e-7
    for j in range(4):
        dx = np.zeros(4)
        dx[j] = h
        fd = (np.array(NOMINAL.deriv(x + dx, 0, 0)) - np.array(NOMINAL.deriv(x - dx, 0, 0))) / 2 / h
        np.testing.assert_allclose(J[:, j], fd, rtol=1e-5, atol=1e-3)


@pytest.mark.parametrize("dv", [-0.5, -3.0])
def test_the_held_damper_keeps_its_peak_force_and_its_jacobian_matches(dv: float) -> None:
    held = dataclasses.replace(NOMINAL, damper_hold=True)
    peak = -NOMINAL.c1 / (2 * NOMINAL.c2)
    assert held.damper(dv) == NOMINAL.damper(max(dv, peak))
    x = np.array([0.02, dv, -0.01, 0.0])
    J = held.jacobian(x)
    for j in range(4):
        step = np.zeros(4)
        step[j] = 1e-7
        fd = (np.array(held.deriv(x + step, 0, 0)) - np.array(held.deriv(x - step, 0, 0))) / 2e-7
        np.testing.assert_allclose(J[:, j], fd, rtol=1e-5, atol=1e-3)
    if dv < peak:
        assert J[1, 1] == 0.0  # no damping past the peak, and never negative


def test_the_printed_covariance_update_is_the_short_form() -> None:
    kf = kfui.KfUi(kfui.SPEC.param_values({}))
    rng = np.random.default_rng(1)
    m = rng.normal(size=(4, 4))
    Pb = m @ m.T + np.eye(4)
    H, D = kf.H(np.zeros(4)), kf.D
    K = Pb @ H.T @ np.linalg.inv(kf.R + H @ Pb @ H.T)
    S = 1 / float(D @ kf.Rinv @ (np.eye(4) - H @ K) @ D)
    printed = (np.eye(4) + np.outer(K @ D * S, D) @ kf.Rinv @ H) @ (np.eye(4) - K @ H) @ Pb
    short = (np.eye(4) - K @ H) @ Pb + S * np.outer(K @ D, K @ D)
    np.testing.assert_allclose(printed, short, rtol=1e-6, atol=1e-8)


def test_the_euler_kfui_and_the_rk4_kfui_both_track() -> None:
    sc_trace = plants.get("quarter_car").run({"road": 1}, 15.0, 0.01, 2)
    p = kfui.SPEC.param_values({"active": 0})
    for rk4 in (False, True):
        errors = paper.state_errors(kfui.ecu(p, rk4), sc_trace, p)
        assert errors["x_us"] < 0.5 * np.std(sc_trace.truth["x_us"])


def test_the_frequency_response_shows_the_papers_eso_distorting_both_bands() -> None:
    """At ε = 0.1 the observer amplifies the body band and loses the wheel hop: x̂ over the
    ideal 1/s² has gain ~1.3 at 2 Hz and ~0.5 at 9.25 Hz, F̂2 keeps ~1 % at 9.25 Hz. The
    design-1 observer at ε = T/5 follows the conditioning (BP+DI) within 15 % at 2 Hz."""
    from vehil import eso_response

    paper_eso = eso_response.over_ideal(eso.SPEC.param_values({"active": 0}), (2.0, 9.25), 4096)
    assert abs(paper_eso["ESO x_s/a_s"][0]) == pytest.approx(1.32, abs=0.03)
    assert abs(paper_eso["ESO x_us/a_us"][1]) == pytest.approx(0.52, abs=0.03)
    assert abs(paper_eso["ESO F2/a_us"][1]) < 0.02
    fast = eso_response.over_ideal(
        eso.SPEC.param_values({"active": 0, "design": 1, "eps": 0.002}), (2.0, 9.25), 4096
    )
    for key in ("x_s/a_s", "F1/a_s"):
        assert abs(fast[f"ESO {key}"][0] / fast[f"BP+DI {key}"][0] - 1) < 0.15
