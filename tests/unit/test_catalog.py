"""`vehil estimators` and `vehil plants`: what they list, for people and as JSON."""

import json

import pytest

from vehil import cli


def _json(capsys: pytest.CaptureFixture[str], *argv: str):  # noqa: ANN202
    assert cli.main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_estimators_lists_every_spec_with_signals_units_and_q_formats(capsys) -> None:
    listed = {e["name"]: e for e in _json(capsys, "estimators")}
    assert {"acc_kf", "manf", "stlqf", "passthrough"} <= set(listed)
    a_m = listed["acc_kf"]["inputs"][0]
    assert (a_m["name"], a_m["unit"], a_m["q"], a_m["q_format"]) == ("a_m", "m/s^2", 24, "Q7.24")
    assert a_m["fixed_range"] == [-128.0, 128.0 - 2.0**-24]


def test_one_estimator_in_full_has_its_parameters_ranges_defaults_and_rules(capsys) -> None:
    stlqf = _json(capsys, "estimators", "stlqf")
    chi1 = stlqf["params"][0]
    assert (chi1["name"], chi1["unit"], chi1["default"], chi1["lo"], chi1["hi"], chi1["q"]) == (
        "chi1",
        "s",
        1.0,
        0.0,
        10.0,
        24,
    )
    assert "a11..a33 make A positive definite." in stlqf["rules"]
    assert stlqf["modes"] == ["F32", "FIXED"] and stlqf["c_id"] == 30


def test_plants_list_their_measured_and_true_signals_with_units(capsys) -> None:
    braking = {p["name"]: p for p in _json(capsys, "plants")}["braking"]
    assert {"name": "omega_f", "unit": "rad/s", "doc": ""} in braking["signals"]
    assert any(s["name"] == "v" and s["unit"] == "m/s" for s in braking["truth"])
    assert _json(capsys, "plants", "braking")["params"] == braking["params"]


def test_tables_show_units_as_text_and_an_unknown_name_is_refused(capsys) -> None:
    assert cli.main(["estimators", "acc_kf"]) == 0
    out = capsys.readouterr().out
    assert "m/s^2" in out and "Q7.24" in out and "lpf_hz T <= 0.4" in out
    assert cli.main(["plants", "nope"]) == 2
    said = capsys.readouterr()
    assert "no plant 'nope'; known: acc_drive" in said.out + said.err
