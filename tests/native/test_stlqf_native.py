"""STLQF and RLS in C (float32) against their float64 references (seed 002)."""

import dataclasses

import numpy as np
import pytest

from vehil import scenario
from vehil.boards import open_board
from vehil.errors import BoardError
from vehil.estimators import stlqf


@pytest.mark.parametrize(
    ("name", "output", "limit"),
    [
        ("paper-dither", "m", 0.05),
        ("paper-dither-fixed", "m", 0.05),  # the first window's step from 1000 kg included
        ("paper-dither-fixed", "grade", 0.5),
        ("mass-step", "m", 2.0),
        ("well-excited-adaptive", "m", 0.05),  # μ adapting down to 1e-4
        ("well-excited-adaptive", "grade", 0.5),
        ("rls-flat-steps", "grade", 0.5),
        ("rls-flat-steps-fixed", "grade", 6.0),
        # Unlike the shipped drives (the first window's step from 1000 kg included):
        ("heavy-rolling-fixed", "m", 0.2),  # 1650 kg, rolling road
        ("van-rolling-fixed", "m", 0.5),  # 2500 kg, 1.2 m²: 0.37 kg in the first window
        ("light-50hz-fixed", "grade", 0.15),  # 1200 kg at 50 Hz: 0.092° as the window fills
        ("heavy-200hz-fixed", "m", 3.0),  # 3440 kg at 200 Hz: 2.5 kg in the first window
        ("rls-heavy-fixed", "m", 0.05),  # unlike the shipped drives: 1650 kg from 1000 kg
        ("rls-heavy-rolling-fixed", "m", 0.5),
        ("rls-truck-fixed", "cda", 2.0),
        ("rls-heavy-200hz-fixed", "cda", 0.1),  # 2.9 t braking past 32 kN: 13.5 m² before
    ],
)
def test_c_follows_the_reference(run_scenario, name, output, limit) -> None:  # noqa: ANN001
    result = run_scenario(name, board="native", duration=45.0)
    result.assert_passed()
    assert result.figures.outputs[output].reference.max_abs < limit


@pytest.mark.parametrize(
    ("name", "limits"),
    [  # measured 0.014 kg, 0.083° and 0.0091 kg, 0.012°, as before the Gram sums by linalg/bfp24
        ("heavy-rolling-fixed", {"m": 0.05, "grade": 0.3}),
        ("van-rolling-fixed", {"m": 0.05, "grade": 0.1}),
    ],
)
def test_float32_follows_the_reference_on_drives_unlike_the_shipped(
    run_scenario, name, limits
) -> None:  # noqa: ANN001
    """The FIXED drives (other mass, drag area and a rolling road) in float32: m and the
    grade within their limits of float64, C_dA_f within the drive's own tolerance once v²
    has excited it for 5 s."""
    sc = scenario.load(name)
    tolerances = {
        k: dataclasses.replace(t, abs=limits[k], rel=0.0, bit_exact=False)
        if k in limits
        else dataclasses.replace(t, bit_exact=False, from_s=5.0)
        for k, t in sc.tolerances.items()
    }
    sc = dataclasses.replace(sc, mode="F32", tolerances=tolerances)
    run_scenario(sc, board="native").assert_passed()


def _reference_flags(reference: stlqf.Stlqf | stlqf.Rls, inputs: np.ndarray) -> np.ndarray:
    """The float64 reference's ILL_CONDITIONED, sample by sample."""
    flags = []
    for u in inputs:
        reference.step(u)
        flags.append(bool(reference.flags & stlqf.ILL_CONDITIONED))
    return np.array(flags)


@pytest.mark.parametrize("mode", ["F32", "FIXED"])
def test_ill_conditioned_says_when_the_prior_holds_the_mass_not_the_data(
    run_scenario, mode
) -> None:  # noqa: ANN001, E501
    """The paper's smooth-throttle drive leaves the window's system singular: μ = 1e-2 held
    the mass ~940 kg off without a flag (a condition number cannot tell, μ bounds it).
    The prior's share of m̂ says it; on a well-excited drive it stays low even with
    μ = 1e-4 (where a condition threshold fired on 5990 of 6000 steps)."""
    held = dataclasses.replace(scenario.load("paper"), mode=mode)
    result = run_scenario(held, board="native", duration=30.0)
    flagged = (result.run.status & stlqf.ILL_CONDITIONED) != 0
    assert result.figures.outputs["m"].truth.rmse > 500
    assert flagged.mean() > 0.6
    expected = _reference_flags(stlqf.Stlqf(held.params), result.run.prepared.inputs)
    assert np.mean(flagged == expected) > 0.97
    sc = scenario.load("heavy-rolling-fixed")
    good = dataclasses.replace(sc, mode=mode, params=sc.params | {"mu": 1e-4, "mu_min": 1e-4})
    result = run_scenario(good, board="native", duration=30.0)
    assert result.figures.status["ILL_CONDITIONED"] <= 3


@pytest.mark.parametrize("mode", ["F32", "FIXED"])
def test_rls_ill_conditioned_says_when_the_prior_holds_an_estimate(run_scenario, mode) -> None:  # noqa: ANN001
    """Cruising at a constant throttle (rls-no-excitation-fixed), ψ barely moves within RLS's
    ~0.2 s memory: the forgetting lets P grow to the windup guard in the directions the data
    do not pin, and a variance above held_max P(0) says so, as in float64. A dithered throttle
    (rls-heavy-fixed) keeps every variance low once the first samples have moved P off P(0)."""
    held = dataclasses.replace(scenario.load("rls-no-excitation-fixed"), mode=mode)
    result = run_scenario(held, board="native")
    result.assert_passed()
    flagged = (result.run.status & stlqf.ILL_CONDITIONED) != 0
    assert flagged.mean() > 0.9
    expected = _reference_flags(stlqf.Rls(held.params), result.run.prepared.inputs)
    # FIXED agrees on all but a few steps; float32's P carries 24 bits (95 % agree)
    assert np.mean(flagged == expected) > (0.99 if mode == "FIXED" else 0.9)
    excited = dataclasses.replace(scenario.load("rls-heavy-fixed"), mode=mode)
    result = run_scenario(excited, board="native")
    flagged = (result.run.status & stlqf.ILL_CONDITIONED) != 0
    assert flagged[:40].all()  # P(0): the prior holds every estimate at the start
    assert not flagged[100:].any()


def test_a_weight_matrix_that_is_not_positive_definite_is_refused_with_a11(built) -> None:  # noqa: ANN001
    spec = stlqf.STLQF
    values = spec.param_values({"a11": 1.0, "a12": 3.0})
    with open_board("native") as link, pytest.raises(BoardError, match="BAD_PARAM") as exc:
        link.configure("stlqf", "F32", spec.encode_params(values, "F32"))
    assert exc.value.detail == [p.name for p in spec.params].index("a11")


@pytest.mark.parametrize("mode", ["F32", "FIXED"])
def test_rls_refuses_a_forgetting_per_time_past_its_range_per_sample(built, mode) -> None:  # noqa: ANN001
    """λ = 0.95 per 0.1 ms is 0.006 per 10 ms step, below λ's 0.5: BAD_PARAM t_ref, as the
    spec's rule says before any board."""
    spec = stlqf.RLS
    values = spec.param_values({"t_ref": 1e-4, "T": 0.01})
    assert "below 0.5 per sample" in " ".join(spec.rule_problems(values, mode))
    with open_board("native") as link, pytest.raises(BoardError, match="BAD_PARAM") as exc:
        link.configure("rls", mode, spec.encode_params(values, mode))
    assert exc.value.detail == [p.name for p in spec.params].index("t_ref")
    ok = spec.param_values({"t_ref": 0.01, "T": 0.005})  # 0.95 per 10 ms: 0.9747 a step
    assert stlqf.per_sample_lambda(ok) == pytest.approx(0.95**0.5)
    with open_board("native") as link:
        link.configure("rls", mode, spec.encode_params(ok, mode))


def test_the_prefilter_in_c_follows_the_reference(run_scenario) -> None:  # noqa: ANN001
    result = run_scenario("noisy-prefilter", board="native", duration=20.0)
    assert result.figures.outputs["m"].reference.rmse < 5.0


@pytest.mark.parametrize(
    ("spec", "change", "named"),
    [
        (stlqf.RLS, {"prefilter_hz": 1.0}, "prefilter_hz"),
        (stlqf.STLQF, {"prefilter_hz": 1.0}, "prefilter_hz"),
        # χ2/T² = 1.1e6: past 2^20 the error filter's int64 sums could overflow.
        (stlqf.STLQF, {"chi2": 1.1, "T": 1e-3}, "chi2"),
    ],
)
def test_fixed_point_refuses_what_it_cannot_hold_naming_it(built, spec, change, named) -> None:  # noqa: ANN001
    values = spec.param_values(change)
    with open_board("native") as link, pytest.raises(BoardError, match="BAD_PARAM") as exc:
        link.configure(spec.name, "FIXED", spec.encode_params(values, "FIXED"))
    assert exc.value.detail == [p.name for p in spec.params].index(named)


@pytest.mark.parametrize("mode", ["F32", "FIXED"])
def test_stlqf_flags_inputs_past_its_bounds_as_clamped(built, mode) -> None:  # noqa: ANN001
    spec = stlqf.STLQF
    with open_board("native") as link:
        link.configure("stlqf", mode, spec.encode_params(spec.param_values({}), mode))
        fine, fast = link.pipeline(
            ("SAMPLE", {"inputs": spec.encode_inputs(u, mode)})
            for u in ([10.0, 1.0, 1500.0], [90.0, 1.0, 1500.0])  # the second past 82 m/s
        )
    assert not fine.fields()["status"] & 0x08 and fast.fields()["status"] & 0x08


def test_a_scenario_that_fixed_point_refuses_names_the_parameter(built, tmp_path) -> None:  # noqa: ANN001
    from rich.console import Console

    from vehil import runner, scenario

    text = (scenario.SCENARIO_DIR / "stlqf" / "paper-dither-fixed.toml").read_text()
    path = tmp_path / "prefiltered.toml"
    extra = "[estimator.params]\nprefilter_hz = 1.0\n"
    path.write_text(text.replace("duration = 75.0", "duration = 1.0") + extra)
    with pytest.raises(scenario.ScenarioError, match="prefilter_hz must be 0 in FIXED"):
        scenario.load(str(path))  # the spec's rule, before any board
    # and the board's own refusal, should a scenario get past the host:
    sc = scenario.load("stlqf/paper-dither-fixed")
    sc = dataclasses.replace(sc, duration=1.0, params={**sc.params, "prefilter_hz": 1.0})
    run = runner.run(sc, "native", console=Console(quiet=True))
    assert run.ended == "failed"
    assert "prefilter_hz = 1 Hz, is in [0, 50]" in run.error
    assert "stlqf in FIXED refuses it" in run.error


@pytest.mark.parametrize("mode", ["F32", "FIXED"])
def test_rls_holds_its_estimate_on_a_sample_past_its_bounds(built, mode) -> None:  # noqa: ANN001
    """A sample no road vehicle makes (16 m/s², a plant's shift transient) is not learnt from
    in any mode, as float64 does not (stlqf.Rls); a 3.5 t vehicle braking at 1.2 g (41 kN,
    past the 32 kN FIXED held before) is."""
    spec = stlqf.RLS

    def sample(v: float, v_dot: float, m: float = 1500.0) -> list[float]:  # 0.5 m², level
        return [v, v_dot, m * v_dot + 0.5 * 0.603 * v * v + m * 9.81 * 0.015]

    drive = [sample(10.0 + 0.1 * k, (-1.0) ** k) for k in range(40)]
    truck = [sample(14.0, -11.8, 3500.0), sample(14.0, 30.0), sample(14.0, 1.5)]  # 30 > 16
    with open_board("native") as link:
        link.configure("rls", mode, spec.encode_params(spec.param_values({}), mode))
        replies = list(
            link.pipeline(
                ("SAMPLE", {"inputs": spec.encode_inputs(u, mode)}) for u in [*drive, *truck]
            )
        )
    heavy, clamped, after = (r.fields() for r in replies[-3:])
    before = replies[-4].fields()
    assert not heavy["status"] & 0x08 and heavy["outputs"] != before["outputs"]  # learnt
    assert clamped["status"] & 0x08
    assert clamped["outputs"] == heavy["outputs"]  # held: not learnt from
    assert after["outputs"] != clamped["outputs"] and not after["status"] & 0x09


@pytest.mark.parametrize("mode", ["F32", "FIXED"])
def test_rls_a_grade_past_asin_s_domain_is_clamped_not_saturated(run_scenario, mode) -> None:  # noqa: ANN001
    """A 3,383 kg van on a road rolling 4° at 1 rad/s (a `sweep-rls` drive in FIXED): RLS's
    m sin / m passes ±1, and past ±2 in places, on the same samples in both modes, float64's
    grade at ±90° there. That is CLAMPED, as float32 says it; FIXED said SATURATED where the
    ratio passed its Q30's ±2, which is no format sized too small."""
    sc = scenario.load("sweep-rls")
    params = {"mass": 3383.146, "cda": 1.4816, "f_roll": 0.0114, "grade_deg": 4.0324}
    params |= {"grade_rad_s": 0.9935, "noise_scale": 0.0628, "v_dot_bias": 0.0708, "z_bias": 19.89}
    sc = dataclasses.replace(
        sc, mode=mode, seed=23, duration=20.0, plant_params={**sc.plant_params, **params}
    )
    status = run_scenario(sc, board="native").figures.status
    assert status["CLAMPED"] > 100 and status["SATURATED"] == 0


@pytest.mark.parametrize("mode", ["F32", "FIXED"])
def test_rls_with_a_long_memory_and_the_grade_a_random_walk_holds_the_mass(
    run_scenario, mode
) -> None:  # noqa: ANN001
    """A noisy 2300 kg van on a rolling road at 200 Hz: λ per second with θ3 a random walk
    (q_grade) keeps m within 35 kg of the truth (28 kg RMS); λ = 0.95 a sample leaves it by
    ~1000 kg. The board follows float64 either way."""
    sc = dataclasses.replace(scenario.load("rls-walk-noisy-fixed"), mode=mode, duration=20.0)
    if mode == "F32":
        sc = dataclasses.replace(
            sc,
            tolerances={
                k: dataclasses.replace(t, bit_exact=False) for k, t in sc.tolerances.items()
            },
        )
    run_scenario(sc, board="native").assert_passed()
    paper = dataclasses.replace(sc, params={**sc.params, "t_ref": 0.0, "q_grade": 0.0})
    figures = run_scenario(paper, board="native").figures
    assert figures.outputs["m"].truth.rmse > 300.0


@pytest.mark.parametrize("mode", ["F32", "FIXED"])
def test_stlqf_ill_conditioned_says_when_noise_moves_the_mass(run_scenario, mode) -> None:  # noqa: ANN001
    """With σ_N = 1 N on the force (heavy-rolling-fixed's car) the window's data fix the mass,
    but the error filter's gain makes m̂ swing by kilograms a window (46 kg RMS from the
    truth): m̂'s mean step passes jitter_max and the flag fires, as in float64; the same
    drive with the plant's 1e-4 N raises it on 3 of 6,000 steps (above)."""
    sc = scenario.load("heavy-rolling-fixed")
    noisy = dataclasses.replace(
        sc, mode=mode, plant_params={**sc.plant_params, "sigma_n": 1.0}, duration=10.0
    )
    result = run_scenario(noisy, board="native")
    flagged = (result.run.status & stlqf.ILL_CONDITIONED) != 0
    assert result.figures.outputs["m"].truth.rmse > 20.0
    assert flagged[200:].all()
    expected = _reference_flags(stlqf.Stlqf(noisy.params), result.run.prepared.inputs)
    assert np.mean(flagged == expected) > 0.99
