"""Tolerances from an error budget: the reference rerun with its arithmetic's rounding."""

import dataclasses

import numpy as np
import pytest

from vehil import scenario, tolerances
from vehil.runner import prepare


def test_what_only_passes_through_keeps_the_inputs_rounding_and_nothing_more() -> None:
    sc = dataclasses.replace(scenario.load("sine"), duration=2.0)
    prepared = prepare(sc)
    out = tolerances.perturbed(prepared, 2.0**-24, 1)
    diff = np.abs(out[:, 0] - prepared.reference[:, 0])
    assert 0 < diff.max() <= 2.0**-24 * np.abs(prepared.inputs[:, 0]).max()


def test_a_filter_amplifies_what_it_computes_and_fixed_reaches_further_than_float32() -> None:
    """The ESO's conditioning integrates twice behind a high-pass whose poles sit near
    z = 1: the rounding of what it stores reaches the outputs many times over; FIXED's
    coarser rounding further. The suggestion is safety × reach, two digits up."""
    base = dataclasses.replace(scenario.load("s1-sine-eso"), duration=3.0)
    f32 = tolerances.budget(base, trials=1)
    fixed = tolerances.budget(dataclasses.replace(base, mode="FIXED"), trials=1)
    x_us_in = 2.0**-24 * 0.01  # the input's rounding alone, in metres of a ~1 cm motion
    assert f32["x_us"].reach > 10 * x_us_in
    assert fixed["x_us"].reach > 10 * f32["x_us"].reach
    b = fixed["x_r"]
    assert b.tolerance == pytest.approx(4 * b.reach, rel=0.1) and b.tolerance >= 4 * b.reach
    assert b.shipped == 1e-4
    assert "[tolerance.x_r]\nabs = " in tolerances.as_toml(fixed)


def test_vehil_tolerances_of_a_log_scenario_counts_the_log_s_steps(tmp_path, capsys) -> None:  # noqa: ANN001
    from vehil import cli

    rows = "\n".join(f"{k * 0.01:.2f},{np.sin(k * 0.01):.6f}" for k in range(300))
    (tmp_path / "drive.csv").write_text(f"t [s],speed [1]\n{rows}\n")
    sc = tmp_path / "replay.toml"
    sc.write_text(
        '[scenario]\nsample_time = 0.01\n[log]\npath = "drive.csv"\n[log.columns]\n'
        'y = "speed"\n[estimator]\nname = "passthrough"\n[tolerance.y]\nrel = 1.2e-7\n'
    )
    assert cli.main(["tolerances", str(sc), "--trials", "1"]) == 0
    assert "300 steps" in " ".join(capsys.readouterr().out.split())
