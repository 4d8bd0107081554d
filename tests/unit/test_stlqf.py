"""STLQF and RLS (seed 002), float64: the equations as docs/estimators/stlqf.md reads them,
and recovery."""

import math

import numpy as np
import pytest

from vehil import plants
from vehil.estimators import stlqf


def _params(**kw: float) -> dict[str, float]:
    return stlqf.STLQF.param_values(kw)


def test_the_window_system_is_eq_23_with_the_corrected_filter() -> None:
    """G and U equal Σ_k W_kᵀ A W_k and Σ_k W_kᵀ A Z_k written out with α, β, γ of eq. 16
    as corrected (β = -(1/T + 2/T²)) over the 11-sample window, 7 terms, time from the centre."""
    p = _params()
    rng = np.random.default_rng(3)
    v, v_dot, z = 20 + rng.normal(0, 1, 11), rng.normal(0, 1, 11), 2000 + rng.normal(0, 50, 11)
    est = stlqf.Stlqf(p)
    for k in range(11):
        est.step(np.array([v[k], v_dot[k], z[k]]))
    gram, rhs = est.window_system()

    T = p["T"]
    alpha, beta, gamma = 1 + 1 / T + 1 / T**2, -(1 / T + 2 / T**2), 1 / T**2
    assert alpha + beta + gamma == pytest.approx(1.0)
    a = np.array([[5, 3, 2], [3, 5, 3], [2, 3, 5]], float)
    tau = np.arange(11) - 5
    psi = np.column_stack([v_dot, 0.5 * p["rho"] * v**2, np.full(11, p["g"] / math.cos(p["eps"]))])
    phi = np.column_stack([c for j in range(3) for c in (tau * psi[:, j], psi[:, j])])
    filt = lambda x, k: alpha * x[k] + beta * x[k - 1] + gamma * x[k - 2]  # noqa: E731
    g_direct, u_direct = np.zeros((6, 6)), np.zeros(6)
    for k in range(4, 11):
        w = np.array([filt(phi, k - i) for i in range(3)])
        zz = np.array([filt(z, k - i) for i in range(3)])
        g_direct += w.T @ a @ w
        u_direct += w.T @ a @ zz
    np.testing.assert_allclose(gram, g_direct, rtol=1e-6)
    np.testing.assert_allclose(rhs, u_direct, rtol=1e-6)


def test_stlqf_recovers_mass_drag_and_grade_from_a_well_excited_drive() -> None:
    trace = plants.get("longitudinal").run({"road": 2, "dither": 0.05}, 20.0, 0.01, 1)
    u = np.column_stack([trace.signals[n] for n in ("v", "v_dot", "z")])
    est = stlqf.Stlqf(_params(mu=1e-4, mu_min=1e-4))  # float64 needs little regularisation
    out = np.array([est.step(x) for x in u])
    d = stlqf.WL  # the estimate is for the window centre
    for j, name, limit in ((0, "m", 0.5), (1, "cda", 0.05), (2, "grade", 0.5)):
        err = out[500:, j] - trace.truth[name][500 - d : len(out) - d]
        assert np.sqrt(np.mean(err**2)) < limit, name


def test_a_weight_matrix_that_is_not_positive_definite_is_refused() -> None:
    assert stlqf.weights_ok(_params())
    assert stlqf.weights_ok(_params(**stlqf.CODE_WEIGHTS))
    assert not stlqf.weights_ok(_params(a11=1.0, a12=3.0))


def test_rls_recovers_constant_parameters_on_a_flat_road() -> None:
    trace = plants.get("longitudinal").run({"road": 1, "profile": 1}, 30.0, 0.01, 1)
    u = np.column_stack([trace.signals[n] for n in ("v", "v_dot", "z")])
    est = stlqf.Rls(stlqf.RLS.param_values({}))
    out = np.array([est.step(x) for x in u])
    assert abs(out[-1, 0] - 1250.0) < 0.1
    assert abs(out[-1, 1] - 0.48) < 1e-3
    assert abs(out[-1, 2]) < 0.01


def test_stlqf_takes_a_sample_no_vehicle_makes_clamped_to_the_bounds() -> None:
    """As FIXED does: the same estimates as with the clamped sample, and CLAMPED."""
    p = stlqf.STLQF.param_values({})
    past, clamped = stlqf.Stlqf(p), stlqf.Stlqf(p)
    for k in range(20):
        u = np.array([10.0 + 0.1 * k, (-1.0) ** k, 1500.0 * (-1.0) ** k + 200.0])
        shock = k == 12
        big = u * [1.0, 30.0, 60.0]  # 30 m/s², 90 kN
        a = past.step(big if shock else u)
        b = clamped.step(np.clip(big, -stlqf.BOUNDS, stlqf.BOUNDS) if shock else u)
        assert np.array_equal(a, b) and bool(past.flags & stlqf.CLAMPED) == shock


def test_rls_learns_nothing_from_a_sample_no_vehicle_makes() -> None:
    """Past |v̇| 16 m/s², |z| 65.5 kN or v 82 m/s (FIXED's bounds) the estimate is held and
    CLAMPED raised; a 4 t vehicle at 1.6 g is inside them."""
    rls = stlqf.Rls(stlqf.RLS.param_values({}))
    before = rls.step(np.array([10.0, 1.0, 1500.0]))
    for u in ([10.0, 17.0, 1500.0], [10.0, 1.0, -70_000.0], [90.0, 1.0, 1500.0]):
        assert np.array_equal(rls.step(np.array(u)), before) and rls.flags & stlqf.CLAMPED
    assert not np.array_equal(rls.step(np.array([10.0, -15.9, -63_600.0])), before)
    assert not rls.flags & stlqf.CLAMPED


def test_the_plant_satisfies_the_regression_it_feeds() -> None:
    """Eq. 24 holds sample by sample once the car moves (σ_N only on z)."""
    trace = plants.get("longitudinal").run({}, 30.0, 0.01, 2)
    s, t = trace.signals, trace.truth
    beta = np.radians(t["grade"])
    lhs = t["m"] * s["v_dot"] + t["cda"] * 0.5 * 1.206 * s["v"] ** 2
    lhs += t["m"] * 9.81 * (0.015 * np.cos(beta) + np.sin(beta))
    moving = s["v"] > 0.5
    assert np.abs(lhs - s["z"])[moving].max() < 1e-2
    assert 300 < np.sum(s["v"]) * 0.01 < 600  # from rest: ~0.4 km in the first 30 s


def test_rolling_resistance_and_sensor_biases_reach_the_regression_as_declared() -> None:
    """f_roll changes the car, the biases offset v̇ and z, noise_scale scales the sensors'
    σ (0: exact sensors even with noise = 1)."""
    run = plants.get("longitudinal").run
    base = run({"noise": 1, "noise_scale": 0.0}, 10.0, 0.01, 2)
    off = run({"noise": 1, "noise_scale": 0.0, "v_dot_bias": 0.05, "z_bias": -20.0}, 10.0, 0.01, 2)
    assert np.allclose(off.signals["v_dot"] - base.signals["v_dot"], 0.05)
    assert np.allclose(off.signals["z"] - base.signals["z"], -20.0)
    exact = run({"sigma_n": 0.0}, 10.0, 0.01, 2)
    assert np.array_equal(base.signals["v"], exact.signals["v"])
    assert np.array_equal(base.signals["z"], exact.signals["z"])
    noisy = run({"noise": 1, "noise_scale": 2.0}, 10.0, 0.01, 2)
    assert np.std(noisy.signals["v"] - exact.signals["v"]) == pytest.approx(0.1, rel=0.1)
    rolling = run({"f_roll": 0.025, "sigma_n": 0.0}, 10.0, 0.01, 2)
    assert rolling.truth["v_true"][-1] < exact.truth["v_true"][-1]


def _scenario(tmp_path, csv_text: str):  # noqa: ANN001, ANN202
    from vehil import scenario

    (tmp_path / "drive.csv").write_text(csv_text)
    path = tmp_path / "gps.toml"
    path.write_text(
        '[scenario]\ntitle = "GPS log"\nduration = 10.0\nsample_time = 0.01\n'
        '[plant]\nname = "longitudinal"\ngps = "drive.csv"\n'
        '[estimator]\nname = "stlqf"\nmode = "F32"\n'
    )
    return scenario.load(path)


def test_a_gps_log_from_csv_gives_the_grade_the_paper_pipeline_gives(tmp_path) -> None:  # noqa: ANN001
    from vehil.plants.longitudinal import process_gps

    t = np.arange(0.0, 12.0)
    speed, alt = np.linspace(0, 15, 12), 100 + 0.8 * np.sin(t / 2)
    rows = "\n".join(f"{a},{b},{c}" for a, b, c in zip(t, speed, alt, strict=True))
    sc = _scenario(tmp_path, "t [s],speed [m/s],altitude [m]\n" + rows + "\n")
    trace = plants.get("longitudinal").run(sc.plant_params, sc.duration, sc.sample_time, 1)
    expected = process_gps(t, speed, alt, trace.t, False)
    np.testing.assert_allclose(trace.truth["grade"], expected, atol=1e-9)


def test_a_gps_log_in_other_units_is_converted_and_a_wrong_one_refused(tmp_path) -> None:  # noqa: ANN001
    from vehil.scenario import ScenarioError

    def grade(text: str) -> np.ndarray:
        sc = _scenario(tmp_path, text)
        return plants.get("longitudinal").run(sc.plant_params, 2.0, 0.01, 1).truth["grade"]

    rows = [(k, 3.6 * k, 100 + 0.5 * k) for k in range(12)]
    in_si = "t [s],speed [m/s],altitude [m]\n" + "".join(f"{t},{v / 3.6},{a}\n" for t, v, a in rows)
    # a German spreadsheet's export: `;`, decimal commas, km/h and altitude in feet
    de = "t [s];speed [km/h];altitude [ft]\n" + "".join(
        f"{t};{v:.1f};{a / 0.3048!r}\n".replace(".", ",") for t, v, a in rows
    )
    np.testing.assert_allclose(grade(de), grade(in_si), atol=1e-9)
    with pytest.raises(
        ScenarioError, match=r"drive.csv: column 'speed' is in 'm'; gps needs 'm/s' \("
    ):
        _scenario(tmp_path, "t [s],speed [m],altitude [m]\n0,0,100\n1,5,101\n")


def _drive_errors(p: dict[str, float], plant: dict[str, float]) -> tuple[np.ndarray, float]:
    """m, C_dA_f and grade RMS errors from 5 s, and the ILL_CONDITIONED rate."""
    trace = plants.get("longitudinal").run(plant, 20.0, 0.01, 2)
    u = np.column_stack([trace.signals[n] for n in ("v", "v_dot", "z")])
    est = stlqf.Stlqf(p)
    out, flagged = [], []
    for x in u:
        out.append(est.step(x))
        flagged.append(bool(est.flags & stlqf.ILL_CONDITIONED))
    out_a, d = np.array(out), stlqf.WL
    names = ("m", "cda", "grade")
    err = [out_a[500:, j] - trace.truth[n][500 - d : len(out_a) - d] for j, n in enumerate(names)]
    return np.sqrt(np.mean(np.square(err), axis=1)), float(np.mean(flagged))


def test_mu_adapts_a_well_excited_window_gets_the_unregularised_accuracy() -> None:
    """μ between mu_min and mu from the mass's information: on a well-excited drive it
    falls to mu_min and the errors are within 1.3x of the unregularised method's (1e-2 throughout
    doubles them), on the paper's singular drive it stays at mu and the flag fires."""
    good = {"road": 2, "profile": 1, "mass": 1650.0, "cda": 0.62, "dither": 0.05}
    free, _ = _drive_errors(_params(mu=0.0, mu_min=0.0), good)
    held, _ = _drive_errors(_params(mu=1e-2, mu_min=1e-2), good)
    adaptive, rate = _drive_errors(_params(mu=1e-2, mu_min=0.0), good)
    assert np.all(adaptive < 1.3 * free)
    assert held[0] > 1.5 * adaptive[0] and held[2] > 2 * adaptive[2]
    assert rate < 0.01
    _, singular_rate = _drive_errors(_params(mu=1e-2, mu_min=0.0), {"road": 0})
    assert singular_rate > 0.5


def test_mu_min_above_mu_is_refused() -> None:
    assert stlqf.mu_min_below_mu(_params(mu=1e-3, mu_min=1e-2), "F32")
    assert stlqf.mu_min_below_mu(_params(mu=1e-2, mu_min=1e-3), "F32") is None
