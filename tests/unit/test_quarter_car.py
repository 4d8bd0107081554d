"""Seed 003's quarter-car plant: equilibrium, mismatch, roads, integration, closed loop."""

import numpy as np
import pytest

from vehil import plants
from vehil.errors import PlantLimit
from vehil.models.quarter_car import NOMINAL
from vehil.papers.eso import HIFI
from vehil.plants.quarter_car import QuarterCarLoop, simulate_with
from vehil.plants.quarter_car_truth import truth_car

QUIET = {"noise_var": 0.0, "bias_lo": 0.0, "bias_hi": 0.0}


def params(**given: object) -> dict[str, object]:
    return plants.get("quarter_car").param_values(given)


def test_a_flat_road_leaves_the_car_at_rest_and_the_sensors_show_their_bias() -> None:
    trace = simulate_with(params(road_amp=0.0, noise_var=0.0), 2.0, 0.01, 1)
    assert np.abs(trace.truth["x_s"]).max() == 0.0
    assert trace.signals["a_s"].min() >= 0.03 and trace.signals["a_s"].max() <= 0.04


def test_the_truth_differs_from_the_nominal_model() -> None:
    plant = QuarterCarLoop(params(), 0.01, 1)
    assert plant.car.m_s == pytest.approx(1.15 * NOMINAL.m_s)
    assert plant.car.friction == 75.0 and plant.car.k1 != NOMINAL.k1


def test_rk4_at_1_khz_agrees_with_a_finer_grid() -> None:
    a = simulate_with(params(road=1, **QUIET), 5.0, 0.01, 1).truth["x_us"]
    b = simulate_with(params(road=1, dt_int=0.00025, **QUIET), 5.0, 0.01, 1).truth["x_us"]
    assert np.abs(a - b).max() < 1e-3 * np.abs(a).max()


def test_the_sine_road_has_its_amplitude_and_the_iso_class_scales_by_two() -> None:
    sine = simulate_with(params(road=0, road_amp=0.02), 4.0, 0.01, 1).truth["x_r"]
    assert np.abs(sine).max() == pytest.approx(0.02, rel=1e-3)
    c = simulate_with(params(road=2, iso_class=3), 10.0, 0.01, 1).truth["x_r"]
    d = simulate_with(params(road=2, iso_class=4), 10.0, 0.01, 1).truth["x_r"]
    assert np.std(d) / np.std(c) == pytest.approx(2.0, rel=1e-6)  # same noise, 4x the PSD


def test_the_closed_loop_with_no_force_is_the_open_loop_drive() -> None:
    p = params(road=1)
    trace = plants.get("quarter_car").run(p, 2.0, 0.01, 5)
    plant = plants.get("quarter_car").start_loop(p, 0.01, 5)
    for k in range(200):
        _, signals, _ = plant.measure()
        assert signals["a_s"] == trace.signals["a_s"][k]
        plant.apply({"u": 0.0})


def test_a_held_force_lifts_the_body_and_the_wheel_settles_back_on_the_road() -> None:
    trace = simulate_with(params(road_amp=0.0, **QUIET), 8.0, 0.01, 1, force=lambda t, tr: 500.0)
    assert trace.truth["x_us"][:20].min() < -1e-4  # pushed down first (eqs. 4-5's sign)
    assert trace.truth["x_s"][-1] > 0.03 and abs(trace.truth["x_us"][-1]) < 1e-5


def test_a_recorded_profile_is_read_from_csv(tmp_path) -> None:  # noqa: ANN001
    path = tmp_path / "road.csv"
    path.write_text("t [s],x_r [m]\n0,0\n1,0.01\n2,0.01\n")
    trace = simulate_with(params(road_profile=path), 2.0, 0.01, 1)
    assert trace.truth["x_r"][50] == pytest.approx(0.005)
    assert trace.truth["x_r"][-1] == pytest.approx(0.01)


def test_forward_euler_at_100_hz_is_unstable_for_the_wheel_hop_mode() -> None:
    lam = np.linalg.eigvals(NOMINAL.jacobian([0, 0, 0, 0]))
    growth = np.abs(1 + 0.01 * lam)
    assert growth.max() == pytest.approx(1.079, abs=2e-3)  # docs/estimators/kfui.md
    assert np.abs(lam).max() / (2 * np.pi) == pytest.approx(9.25, abs=0.01)


def test_bumps_and_chirp_roads_have_their_shape() -> None:
    bumps = simulate_with(params(road=3, speed_kmh=36, bump_h=0.02, bump_len=1.0), 4.0, 0.01, 1)
    x_r = bumps.truth["x_r"]
    assert x_r.max() == pytest.approx(0.02, abs=2e-4)
    assert np.mean(x_r > 0) == pytest.approx(1.0 / 15.0, abs=0.01)  # 1 m of every 15 m
    chirp = simulate_with(params(road=4, f_lo=1.0, f_hi=9.0, chirp_s=4.0), 4.0, 0.001, 1)
    crossings = np.flatnonzero(np.diff(np.sign(chirp.truth["x_r"])) != 0)
    # 1 -> 9 Hz linearly over 4 s: 20 cycles, 40 zero crossings
    assert len(crossings) == pytest.approx(40, abs=2)


def test_dahl_friction_holds_the_strut_until_the_force_passes_the_coulomb_level() -> None:
    """Under a force below the friction level the Dahl strut stays near where the step left
    it (Dahl's model creeps a little); the tanh Coulomb model creeps on towards the
    spring's equilibrium."""
    quiet = {**QUIET, "road_amp": 0.0, "friction": 300.0, "ms_scale": 1.0, "k1_scale": 1.0}
    dahl = simulate_with(params(friction_k=1e5, **quiet), 6.0, 0.01, 1, force=lambda t, tr: 200.0)
    coulomb = simulate_with(params(**quiet), 6.0, 0.01, 1, force=lambda t, tr: 200.0)
    creep_dahl, creep_coulomb = (np.ptp(tr.truth["defl"][-300:]) for tr in (dahl, coulomb))
    assert creep_dahl < 0.25 * creep_coulomb
    assert 0 < dahl.truth["defl"][-1] < coulomb.truth["defl"][-1]


def test_enveloping_and_sensor_bandwidth_smooth_what_the_car_and_sensors_see() -> None:
    base = {**QUIET, "road": 2, "speed_kmh": 60.0}
    sharp = simulate_with(params(**base), 5.0, 0.01, 1)
    soft = simulate_with(params(**base, patch_len=0.2, acc_bw=20.0), 5.0, 0.01, 1)
    # the same road, its short waves averaged over the patch, the accelerometers band-limited
    assert np.corrcoef(sharp.truth["x_r"], soft.truth["x_r"])[0, 1] > 0.98
    assert np.std(np.diff(soft.signals["a_us"])) < 0.8 * np.std(np.diff(sharp.signals["a_us"]))


ROUGH = {"road": 2, "iso_class": 5, "speed_kmh": 100}  # ISO 8608 class E at 100 km/h


@pytest.mark.parametrize("car", [{}, HIFI], ids=["default", "hifi"])
def test_a_class_e_road_at_100_kmh_stays_finite_and_the_damper_never_pushes(car) -> None:  # noqa: ANN001
    """The literal-square damper reversed past 2 m/s of compression (NaN within 1 s) and
    the hifi car's Dahl friction outran RK4 at 1 kHz; both drives now run to the end."""
    p = params(**ROUGH, **car)
    truth = simulate_with(p, 10.0, 0.01, 1).truth
    assert all(np.isfinite(x).all() for x in truth.values())
    dv = truth["v_s"] - truth["v_us"]
    damper = truth_car(p).damper
    assert min(damper(v) * v for v in dv) >= 0.0  # it dissipates on every sample
    assert dv.min() < -2.0  # and the drive reached the speeds where it used to push
    assert np.abs(truth["defl"]).max() < 0.3  # the strut's cubic spring holds the travel
    assert np.sqrt(np.mean(truth["a_body"] ** 2)) < 30.0


def test_the_literal_damper_holds_its_peak_compression_force() -> None:
    car = truth_car(params())
    peak = -car.c1 / (2 * car.c2)
    assert car.damper(peak) == pytest.approx(-(car.c1**2) / (4 * car.c2))
    assert car.damper(5 * peak) == car.damper(peak)
    assert truth_car(params(damper_hold=0)).damper(5 * peak) > 0  # the paper's law pushes


def test_a_road_a_quarter_car_cannot_drive_is_refused_not_nan() -> None:
    with pytest.raises(PlantLimit, match=r"quarter_car at t = .* s: the wheel is .* above"):
        simulate_with(params(**dict(ROUGH, iso_class=8)), 10.0, 0.01, 1)


def test_the_hifi_car_on_class_h_at_100_kmh_is_refused_not_nan() -> None:
    with pytest.raises(PlantLimit, match="lower the speed or the road class"):
        simulate_with(params(**dict(ROUGH, iso_class=8), **HIFI), 10.0, 0.01, 1)
