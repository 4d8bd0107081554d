"""Sweep perturbations as a scenario or the command line declares them, checked."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from vehil.perturb import parse_option
from vehil.scenario import ScenarioError, parse

BASE = """
[scenario]
duration = 1.0
sample_time = 0.01
[plant]
name = "braking"
m = 1000
[estimator]
name = "uiiekf"
[sweep]
"""


def _load(sweep: str):  # noqa: ANN202
    return parse(tomllib.loads(BASE + sweep), "s.toml")


def test_envelope_outside_the_plants_range_is_refused_naming_it() -> None:
    with pytest.raises(
        ScenarioError, match=r"s\.toml: sweep\.m = .*\[50, 1950\] kg.*\[100, 5000\]"
    ):
        _load("m = {rel = 0.95}\n")
    assert _load("m = {rel = 0.9}\n").sweep["m"].lo == 100.0  # on the bound: accepted
    with pytest.raises(ScenarioError, match=r"sweep\.psi .*outside plant braking's range for psi"):
        _load("psi = {abs = 0.8}\n")  # 0.85 ± 0.8 reaches 0.05 < 0.1


def test_unknown_parameter_and_bad_form_are_named() -> None:
    with pytest.raises(ScenarioError, match=r"sweep\.mass: plant braking has no parameter mass"):
        _load("mass = {rel = 0.1}\n")
    with pytest.raises(ScenarioError, match=r"sweep\.m: give exactly one of"):
        _load("m = {rel = 0.1, abs = 5}\n")
    with pytest.raises(ScenarioError, match=r"sweep\.m: lo = 900 is above hi = 800"):
        _load("m = {lo = 900, hi = 800}\n")


def test_draws_stay_in_the_declared_envelope() -> None:
    sc = _load("m = {rel = 0.2}\nsurface = {values = [0, 2, 4]}\n")
    m, surface = sc.sweep["m"], sc.sweep["surface"]
    assert (m.lo, m.hi) == pytest.approx((800.0, 1200.0))  # around the scenario's 1000, not 850
    rng = np.random.default_rng(0)
    ms = [m.draw(rng) for _ in range(200)]
    assert 800 <= min(ms) < 850 and 1150 < max(ms) <= 1200
    assert {surface.draw(rng) for _ in range(50)} == {0.0, 2.0, 4.0}


def test_a_log_scenario_cannot_sweep() -> None:
    data = tomllib.loads(
        BASE.replace('[plant]\nname = "braking"\nm = 1000', '[log]\npath = "x.csv"')
    )
    data["sweep"] = {"m": {"rel": 0.1}}
    with pytest.raises(ScenarioError, match=r"\[sweep\] varies a plant"):
        parse(data, "s.toml")


def test_command_line_form() -> None:
    assert parse_option("m:rel=0.15") == ("m", {"rel": 0.15})
    assert parse_option("m:lo=900,hi=1100") == ("m", {"lo": 900.0, "hi": 1100.0})
    assert parse_option("surface:values=0/2") == ("surface", {"values": [0.0, 2.0]})
    with pytest.raises(ValueError, match="NAME:rel=R"):
        parse_option("m=0.15")
    with pytest.raises(ValueError, match="'x' is not a number"):
        parse_option("m:rel=x")
