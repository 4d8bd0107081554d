"""The ACC filter's C (float32 and fixed point) against its float64 reference."""

import dataclasses

import numpy as np
import pytest

from vehil import plants, scenario
from vehil.boards import open_board
from vehil.errors import BoardError
from vehil.estimators import acc_kf
from vehil.protocol.schema import SCHEMA


@pytest.mark.parametrize(("name", "limit"), [("mixed", 5e-5), ("mixed-fixed", 1e-4)])
def test_c_follows_the_reference(run_scenario, name, limit) -> None:  # noqa: ANN001
    result = run_scenario(name, board="native", duration=30.0)
    result.assert_passed()
    assert result.figures.outputs["v"].reference.max_abs < limit


def test_an_out_of_range_parameter_is_refused_with_its_index(built) -> None:  # noqa: ANN001
    values = acc_kf.spec_defaults() | {"R": 0.0}  # the reference would divide by zero too
    spec = acc_kf.SPEC
    with open_board("native") as link, pytest.raises(BoardError, match="BAD_PARAM") as exc:
        link.configure("acc_kf", "F32", spec.encode_params(values, "F32"))
    assert exc.value.detail == [p.name for p in spec.params].index("R")


def test_the_four_variants_run_on_the_board_as_on_the_host(run_scenario) -> None:  # noqa: ANN001
    sc = scenario.load("mixed")
    for corr1, corr2 in ((0, 0), (1, 0), (0, 1)):
        params = sc.params | {"corr1": float(corr1), "corr2": float(corr2)}
        result = run_scenario(dataclasses.replace(sc, params=params), board="native", duration=20.0)
        assert result.figures.outputs["v"].reference.max_abs < 1e-4


@pytest.mark.parametrize(
    "change",
    [{"lpf_hz": 0.0}, {"lpf_hz": 30.0}, {"corr1": 0.0}, {"corr2": 0.0}, {"R": 0.004}],
)
def test_fixed_follows_the_reference_off_the_shipped_parameters(run_scenario, change) -> None:  # noqa: ANN001
    """The low-pass off or at 30 Hz (its unit-DC-gain form), one correction off, a smaller R
    (larger gains, kept as 16-bit factors): FIXED within 1e-4 of float64."""
    sc = scenario.load("mixed-fixed")
    changed = dataclasses.replace(sc, params=sc.params | change)
    result = run_scenario(changed, board="native", duration=20.0)
    result.assert_passed()
    assert result.figures.outputs["v"].reference.max_abs < 1e-4
    assert result.figures.outputs["a0"].reference.max_abs < 1e-4


@pytest.mark.parametrize(("name", "limit"), [("mixed", 5e-5), ("mixed-fixed", 2e-4)])
def test_at_1_ms_only_the_sample_time_changes_and_the_c_derives_the_same_step(
    run_scenario,  # noqa: ANN001
    name: str,
    limit: float,
) -> None:
    sc = scenario.load(name)
    fast = dataclasses.replace(sc, sample_time=0.001, params=sc.params | {"T": 0.001})
    result = run_scenario(fast, board="native", duration=20.0)
    result.assert_passed()
    assert result.figures.outputs["v"].reference.max_abs < limit


def test_a_low_pass_cutoff_too_high_for_the_sample_time_is_refused(built) -> None:  # noqa: ANN001
    values = acc_kf.spec_defaults() | {"T": 0.01, "lpf_hz": 45.0}
    with pytest.raises(ValueError, match="lpf_hz = 45 Hz is above"):
        acc_kf.AccKF(values)
    with open_board("native") as link, pytest.raises(BoardError, match="BAD_PARAM") as exc:
        link.configure("acc_kf", "FIXED", acc_kf.SPEC.encode_params(values, "FIXED"))
    assert exc.value.detail == [p.name for p in acc_kf.SPEC.params].index("lpf_hz")


@pytest.mark.parametrize("mode", ["F32", "FIXED"])
def test_a_dead_wheel_sensor_sets_diverged_where_the_reference_does(built, mode: str) -> None:  # noqa: ANN001
    """The right wheel reads 0 from 20 s on (mixed drive): the innovation's windowed mean
    leaves its white-noise spread by ~60 σ and the filter says DIVERGED; not before. The
    mean passes through 0 once, where the innovation turns from the drop (v̂ falls to the
    half speed) to the bias it left (v̂ climbs back): 0.15 s of the 10."""
    sc = scenario.load("mixed")
    trace = plants.get("acc_drive").run(sc.plant_params, 30.0, 0.01, sc.seed)
    u = np.column_stack([trace.signals[n] for n in ("a_m", "omega_l", "omega_r", "brake")])
    u[2000:, 2] = 0.0
    spec = acc_kf.SPEC
    with open_board("native") as link:
        link.configure("acc_kf", mode, spec.encode_params(sc.params, mode))
        requests = (("SAMPLE", {"inputs": spec.encode_inputs(x, mode)}) for x in u)
        status = np.array([r.fields()["status"] for r in link.pipeline(requests)])
    flagged = (status & SCHEMA.status["DIVERGED"]) != 0
    reference = acc_kf.AccKF(sc.params)
    for x in u:
        reference.step(spec.quantise_inputs(x, mode))
    assert not flagged[:2000].any() and flagged[2001:2200].all() and flagged[2300:].all()
    assert np.mean(flagged[2001:]) > 0.98
    assert np.mean(flagged == np.array(reference.diverged)) > 0.99
