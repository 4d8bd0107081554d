"""Seed 001's references (float64): the EV model, EKF, UKF, UPF and the adaptive R."""

import dataclasses
import math

import numpy as np
import pytest

from vehil import plants
from vehil.estimators import upf
from vehil.models import ev4wd as ev

S1 = {"manoeuvre": 0, "speed": 80.0, "mu": 0.85, "dlc_offset": 3.5, "dlc_length": 20.0}


@pytest.fixture(scope="module")
def lane_change() -> tuple[np.ndarray, dict[str, np.ndarray]]:
    trace = plants.get("ev4wd").run(S1, 12.0, 0.01, 1)
    z = np.column_stack([trace.signals[s.name] for s in ev.INPUTS])
    return z, trace.truth


def _params(**kw: float) -> dict[str, float]:
    return upf.UKF.param_values({"mu": 0.85, "vx0": 22.22, **kw})


@pytest.mark.parametrize("make", [upf.Ekf, upf.Ukf], ids=["ekf", "ukf"])
def test_ekf_and_ukf_track_the_plant_through_the_lane_change(lane_change, make) -> None:  # noqa: ANN001
    z, truth = lane_change
    est = make(_params())
    out = np.array([est.step(x) for x in z])[100:]
    fy = np.stack([truth[f"fy{i}"] for i in range(1, 5)], axis=1)[100:]
    assert np.abs(fy).max() > 2000  # the tires are well loaded
    assert np.sqrt(np.mean((out[:, 3:7] - fy) ** 2)) < 60.0
    assert np.sqrt(np.mean((out[:, 0] - truth["vx"][100:]) ** 2)) < 0.05
    assert np.abs(out[:, 7] - truth["beta"][100:]).max() < 0.3  # deg


def test_the_upf_tracks_the_lane_change_with_a_few_particles(lane_change) -> None:  # noqa: ANN001
    z, truth = lane_change
    est = upf.Upf(_params(), n=20, seed=1)
    out = np.array([est.step(x) for x in z[:400]])[100:]
    fy = np.stack([truth[f"fy{i}"] for i in range(1, 5)], axis=1)[100:400]
    assert np.sqrt(np.mean((out[:, 3:7] - fy) ** 2)) < 100.0
    assert np.abs(out[:, 0] - truth["vx"][100:400]).max() < 0.2


@pytest.mark.parametrize(("n", "alpha"), [(7, 1.0), (7, 1e-3), (21, 1e-3)])
def test_sigma_points_reproduce_mean_and_covariance(n, alpha) -> None:  # noqa: ANN001
    rng = np.random.default_rng(n)
    a = rng.normal(size=(n, n))
    P = a @ a.T + n * np.eye(n)
    x = rng.normal(size=n) * 10
    spread, wm, wc = upf.ut_weights(n, alpha, 2.0, 0.0)
    chi = upf.sigma_points(x, P, spread)
    assert chi is not None and chi.shape == (2 * n + 1, n)
    assert wm.sum() == pytest.approx(1.0)
    mean = upf.ut_mean(chi, wm)
    np.testing.assert_allclose(mean, x, atol=1e-9 * np.abs(x).max())
    d = chi - mean
    # W_0^(c) carries 1 - α² + β beyond W_0^(m), and χ_0 - mean is ~0: Σ W^(c) d dᵀ = P.
    np.testing.assert_allclose((wc[:, None] * d).T @ d, P, rtol=1e-6, atol=1e-6)


# The shipped car, and one whose every tire shape term leaves its default (E_y ≠ 0, the
# combined-slip C ≠ 1, B_xα ≠ B_y): the slopes' general forms.
OTHER_TIRES = dataclasses.replace(
    ev.SHIPPED, m=2300.0, i_z=4200.0, e_y=-0.8, c_xa=0.8, c_yk=0.7, b_xa=7.0, b_yk=12.0
)


@pytest.mark.parametrize("car", [ev.SHIPPED, OTHER_TIRES], ids=["shipped", "other-tires"])
def test_the_jacobians_match_finite_differences(lane_change, car) -> None:  # noqa: ANN001
    z, _ = lane_change
    pre = ev.Preprocess(0.01, car)
    for k in range(600):  # mid manoeuvre
        u = pre(z[k])
    x = np.array([22.0, 0.3, 0.15, 1500.0, 1200.0, 900.0, 800.0])
    F, H = ev.jacobians(x, u, car, 0.85, 0.01)
    for j in range(7):
        dx = np.zeros(7)
        dx[j] = 1e-6 * max(1.0, abs(x[j]))
        up, down = (ev.step(x + sg * dx, u, car, 0.85, 0.01) for sg in (1, -1))
        fd_f = (up - down) / (2 * dx[j])
        fd_h = (ev.h(x + dx, u, car, 0.85) - ev.h(x - dx, u, car, 0.85)) / (2 * dx[j])
        # κ̂ depends on α through G_xα, which the Jacobians hold constant: a small gap.
        np.testing.assert_allclose(F[:, j], fd_f, rtol=0.02, atol=1e-4)
        np.testing.assert_allclose(H[:, j], fd_h, rtol=0.02, atol=1e-3)


def test_linear_tires_are_the_mf_slope_at_zero_slip_and_their_slopes_are_exact(lane_change) -> None:  # noqa: ANN001, E501
    z, _ = lane_change
    car = ev.SHIPPED
    pre = ev.Preprocess(0.01, car)
    for k in range(600):
        u = pre(z[k])
    x = np.array([22.0, 0.3, 0.15])
    mf, lin = ev.wheels(x, u, car, 0.85), ev.wheels(x, u, car, 0.85, linear=True)
    np.testing.assert_allclose(lin.fy_qs / lin.alpha, car.b_y * car.c_y * 0.85 * u.fz)
    # The MF saturates below its slope at zero; at a small slip the two agree.
    assert np.all(np.abs(lin.fy_qs) >= np.abs(mf.fy_qs))
    small = ev.wheels(np.array([22.0, 0.0, 0.0]), u, car, 0.85, linear=True)
    small_mf = ev.wheels(np.array([22.0, 0.0, 0.0]), u, car, 0.85)
    assert np.max(np.abs(small.alpha)) < 0.01
    np.testing.assert_allclose(small.fy_qs, small_mf.fy_qs, rtol=0.05, atol=5.0)
    s = ev.slopes(x, u, car, 0.85, lin, linear=True)
    for j in range(3):
        dx = np.zeros(3)
        dx[j] = 1e-6 * max(1.0, abs(x[j]))
        up, down = (ev.wheels(x + sgn * dx, u, car, 0.85, linear=True) for sgn in (1, -1))
        np.testing.assert_allclose(s.dalpha[:, j], (up.alpha - down.alpha) / (2 * dx[j]), rtol=1e-6)
    np.testing.assert_array_equal(s.dk, 0.0)


def _inputs(ax: float = 0.0, ay: float = 0.0, gz: float = 0.0, delta: float = 0.0) -> ev.Inputs:
    fz = ev.loads(ax, ay, ev.SHIPPED)
    return ev.Inputs(delta, np.zeros(4), fz, np.array([ax, ay, gz, 0, 0, 0, 0.0]))


def test_adaptive_r_trusts_the_inertial_sensors_more_when_they_are_excited() -> None:
    p = _params()
    quiet = ev.adaptive_r(_inputs(), np.zeros(4), p)
    busy = ev.adaptive_r(_inputs(ax=2.0, ay=4.0, gz=0.3, delta=math.radians(3)), np.zeros(4), p)
    assert np.all(busy[:3] < quiet[:3])  # rules 1, 3, 4
    assert np.all(busy[1:3] < quiet[1:3] / 3)
    assert np.all(quiet[:3] > ev.fixed_r(p)[:3])  # a quiet inertial sensor is noise


def test_adaptive_r_distrusts_a_slipping_wheel_within_the_clip() -> None:
    p = _params()
    kappa = np.array([0.0, 0.02, 0.1, 2.0])
    r = ev.adaptive_r(_inputs(), kappa, p)[3:]
    assert np.all(np.diff(r) > 0)  # rule 2
    assert r[-1] <= ev.fixed_r(p)[3] * p["r_clip"]


def test_fixed_r_is_the_switch_off() -> None:
    p = _params(adaptive=0.0)
    r = ev.adaptive_r(_inputs(ax=2.0), np.full(4, 0.2), p)
    np.testing.assert_array_equal(r, ev.fixed_r(p))


@pytest.mark.parametrize(("manoeuvre", "sign"), [(2, 1.0), (3, -1.0)])
def test_tcs_and_abs_let_every_wheel_slip_and_catch_it(manoeuvre, sign) -> None:  # noqa: ANN001
    trace = plants.get("ev4wd").run(
        {"manoeuvre": manoeuvre, "mu": 0.3, "speed": 80.0}, 20.0, 0.01, 1
    )
    kappa = np.stack([trace.truth[f"kappa{i}"] for i in range(1, 5)])
    assert np.all((sign * kappa > 0.1).any(axis=1))  # each wheel slips at some point
    slipping = (sign * kappa > 0.1).mean()
    assert 0.01 < slipping < 0.3  # and the controller brings it back


def test_the_plant_can_be_a_car_the_filters_do_not_know() -> None:
    """Sine steering at 80 km/h: a longer relaxation length delays the lateral forces behind
    the steering, load-sensitive tires and a softer B_y lower their peak, a heavier car
    rolls slower to the same turn."""
    ev4wd = plants.get("ev4wd")
    base = {"manoeuvre": 1, "noise": 0, "steer_deg": 2.0}

    def run(**over: float) -> dict[str, np.ndarray]:
        trace = ev4wd.run({**base, **over}, 4.0, 0.01, 1)
        return {"delta": trace.signals["delta"][200:], "fy1": trace.truth["fy1"][200:]}

    def lag(d: dict[str, np.ndarray]) -> int:
        x = np.correlate(d["fy1"] - d["fy1"].mean(), d["delta"] - d["delta"].mean(), "full")
        return int(np.argmax(x)) - (len(d["delta"]) - 1)

    shipped, relaxed = run(), run(sigma_y=1.5)
    assert lag(relaxed) > lag(shipped)
    softer = run(b_y=7.0, load_sens=0.3)
    assert np.abs(softer["fy1"]).max() < 0.95 * np.abs(shipped["fy1"]).max()
