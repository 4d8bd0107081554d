"""`vehil sweep` on the native board: N drives, their distributions, and what mismatch does."""

from __future__ import annotations

import dataclasses
import json

import pytest

from vehil import cli, scenario, sweep
from vehil.errors import PlantLimit

VARY = {"i_w": {"lo": 1.0, "hi": 1.5}, "k_b": {"lo": 0.55, "hi": 0.6}}  # another car's wheels


@pytest.fixture(scope="module")
def uiiekf3(built):  # noqa: ANN001, ANN201
    """UIIEKF (3 states) under the paper's tuning (q_w = 1 (rad/s)²/s, which trusts the
    wheels' torque balance) on 3 drives of a car whose wheel inertia and brake split it does
    not know, and on the same 3 drives told them; "default": not told, the default q_w."""
    sc = scenario.load("uiiekf3-abs-dry")
    paper = dataclasses.replace(sc, params={**sc.params, "q_w": 1.0})
    found = sweep.perturbations(sc, VARY)
    runs = {m: sweep.run(paper, found, 3, "native", matched=m) for m in (False, True)}
    return runs | {"default": sweep.run(sc, found, 3, "native")}


def _row(s: sweep.Sweep, output: str, measure: str) -> dict:
    return next(r for r in s.distributions() if r["output"] == output and r["measure"] == measure)


def test_each_drive_is_drawn_and_counted(uiiekf3) -> None:  # noqa: ANN001
    s = uiiekf3[False]
    assert [d.index for d in s.drives] == [1, 2, 3] and s.nominal.drawn == {}
    assert len({d.drawn["i_w"] for d in s.drives}) == 3
    assert all(1.0 <= d.drawn["i_w"] <= 1.5 and 0.55 <= d.drawn["k_b"] <= 0.6 for d in s.drives)
    assert [d.seed for d in s.drives] == [2, 3, 4]  # the scenario's seed 1 + i
    assert all(r["drives"] == 3 for r in s.distributions())
    assert all(d.figures.samples == 400 for d in (s.nominal, *s.drives))


def test_mismatch_degrades_the_error_and_raises_diverged(uiiekf3) -> None:  # noqa: ANN001
    wrong, told = uiiekf3[False], uiiekf3[True]
    nominal = _row(wrong, "v", "RMS vs truth")["nominal"]
    assert _row(wrong, "v", "RMS vs truth")["median"] > 4 * nominal
    assert (
        _row(wrong, "v", "RMS vs truth")["median"] > 2 * _row(told, "v", "RMS vs truth")["median"]
    )
    diverged = {r["flag"]: r for r in wrong.flags()}["DIVERGED"]
    assert diverged["nominal_samples"] == 0 and diverged["drives"] == 3
    assert told.matched == ("i_w", "k_b")
    assert {r["flag"]: r for r in told.flags()}["DIVERGED"]["drives"] == 0


def test_the_default_process_noise_holds_on_wheels_it_was_not_told(uiiekf3) -> None:  # noqa: ANN001
    """q_w = 300 (rad/s)²/s covers a wheel inertia a third of the filter's and a brake split
    0.1-0.15 off: within 3× the nominal drive's error, better than the paper's tuning told
    the car, and no flag (docs/estimators/uiiekf.md)."""
    default, told = uiiekf3["default"], uiiekf3[True]
    rms = _row(default, "v", "RMS vs truth")
    assert (
        rms["worst"] < 3 * rms["nominal"]
        and rms["median"] < _row(told, "v", "RMS vs truth")["median"]
    )
    assert {r["flag"]: r for r in default.flags()}["DIVERGED"]["drives"] == 0


def test_report_files(uiiekf3) -> None:  # noqa: ANN001
    s = uiiekf3[False]
    md = sweep.write(s)
    text = md.read_text()
    assert "3 perturbed drives" in text and "| i_w | [1, 1.5] |" in text
    assert "| DIVERGED | 0 | 3/3 |" in text
    assert (s.out / "sweep.png").stat().st_size > 10_000
    data = json.loads((s.out / "sweep.json").read_text())
    assert len(data["drives"]) == 4 and data["drives"][0]["drawn"] == {}
    assert all((s.out / f"drive-{i:03d}" / "run.arrow").exists() for i in range(4))


def test_cli_refuses_an_envelope_outside_the_plant(built, capsys) -> None:  # noqa: ANN001
    assert cli.main(["sweep", "uiiekf3-abs-dry", "-n", "2", "--vary", "i_w:rel=0.99"]) == 2
    said = capsys.readouterr().out
    assert "sweep.i_w" in said and "outside plant braking's range for i_w" in said


def test_cli_json(built, tmp_path, capsys) -> None:  # noqa: ANN001
    args = ["sweep", "manf-40kmh-10ms", "-n", "2", "--vary", "wheel_var:lo=0.005,hi=0.05"]
    assert cli.main([*args, "--out", str(tmp_path), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["board"] == "native" and len(data["drives"]) == 3
    assert {r["output"] for r in data["distributions"]} == {"v", "rg"}
    assert (tmp_path / "sweep.md").exists()


def test_an_estimator_that_sees_a_band_is_scored_in_it_too(built, tmp_path) -> None:  # noqa: ANN001
    """The paper's ESO sees the road only through its conditioning's band: the sweep scores
    its displacements against that band's truth as well, beside the all-zero estimate's
    error there; the paper's tuning does worse than estimating nothing (README)."""
    sc = dataclasses.replace(scenario.load("sweep-eso"), duration=6.0)
    s = sweep.run(sc, sweep.perturbations(sc, {}), 2, "native", out=tmp_path)
    assert {"x_s", "x_us", "x_r"} <= {
        r["output"] for r in s.distributions() if r["measure"] == sweep.IN_BAND
    }
    in_band, zero = _row(s, "x_r", sweep.IN_BAND), _row(s, "x_r", sweep.ZERO)
    assert 0 < zero["median"] < _row(s, "x_r", "RMS vs truth")["median"]  # the band's part
    assert in_band["median"] > zero["median"] and s.beats_zero()["x_r"] == 0
    assert "in band, better than the zero estimate: x_s on" in sweep.write(s).read_text()


def test_an_estimator_that_sees_the_whole_truth_is_not(uiiekf3) -> None:  # noqa: ANN001
    s = uiiekf3[False]
    assert s.beats_zero() == {} and all(d.in_band == {} for d in s.drives)


def test_a_drive_the_plant_cannot_model_names_itself(built) -> None:  # noqa: ANN001
    """ISO class H at 100 km/h throws the quarter car off the road: the sweep stops naming
    the drive and its draw, not with NaN figures."""
    sc = dataclasses.replace(scenario.load("mismatch-iso-c60-kfui"), duration=3.0)
    found = sweep.perturbations(sc, {"iso_class": {"values": [8]}, "speed_kmh": {"values": [100]}})
    with pytest.raises(PlantLimit, match=r"drive 1 \(iso_class = 8, speed_kmh = 100\): .*road"):
        sweep.run(sc, found, 1, "native")


def test_an_interrupted_sweep_sums_up_the_drives_it_did_and_says_so(
    built,  # noqa: ANN001
    tmp_path,  # noqa: ANN001
    monkeypatch,  # noqa: ANN001
) -> None:
    from vehil import runner

    real_run = runner.run

    def ctrl_c_at_drive_3(sc, *args, **kwargs):  # noqa: ANN001, ANN002, ANN003, ANN202
        if str(kwargs["recording"]).endswith("drive-003/run.arrow"):
            raise KeyboardInterrupt
        return real_run(sc, *args, **kwargs)

    monkeypatch.setattr(runner, "run", ctrl_c_at_drive_3)
    sc = dataclasses.replace(scenario.load("sweep-manf"), duration=0.05)
    s = sweep.run(sc, sweep.perturbations(sc, {}), 6, out=tmp_path)
    assert len(s.drives) == 2 and s.stop_signal == 2
    assert s.stopped == "interrupted (SIGINT) in drive 3: 2 of 6 perturbed drives done"
    md = sweep.write(s).read_text()
    assert md.splitlines()[2].startswith("**INTERRUPTED**: interrupted (SIGINT) in drive 3")
    assert json.loads((tmp_path / "sweep.json").read_text())["stopped"] == s.stopped
