"""An OBD app's export replayed through the CLI: converted, the conversions in the report;
the recording it gives replays by name, whatever the scenario's [log] maps."""

import pytest

from vehil import cli, record
from vehil.paths import DATA_ROOT

SCENARIO = """
[scenario]
sample_time = 0.1
[log]
path = "torque.csv"
preset = "torque"
[log.columns]
a_m = "Acceleration Sensor(X axis)"
omega_l = { column = "Speed (OBD)", radius = 0.3 }
omega_r = { column = "Speed (OBD)", radius = 0.3 }
brake = 0
[log.truth]
v = "Speed (OBD)"
[estimator]
name = "acc_kf"
[tolerance.v]
abs = 2e-4
rel = 1e-5
"""


@pytest.mark.parametrize("board", ["native", pytest.param("simavr", marks=pytest.mark.hil)])
def test_an_obd_export_replays_with_its_conversions_reported(torque_log, tmp_path, board) -> None:  # noqa: ANN001
    sc = tmp_path / "obd.toml"
    sc.write_text(SCENARIO)
    out = tmp_path / "run"
    args = ["replay", str(torque_log), "--scenario", str(sc), "--board", board, "--out", str(out)]
    assert cli.main(args) == 0
    md = (out / "report.md").read_text()
    assert "## Log inputs" in md
    assert "| omega_l | Speed (OBD) | / radius 0.3 m, (km/h)/m → rad/s | 0.9643 Hz |" in md
    assert "| a_m | Acceleration Sensor(X axis) | g → m/s^2 |" in md
    assert "| brake | constant 0 | 1 |" in md
    rec = record.read(out / "run.arrow")
    assert rec.end["ended"] == "completed"
    # The recording carries a_m, omega_l... by name: the [log] mapping is not applied to it.
    again = ["replay", str(out / "run.arrow"), "--scenario", str(sc), "--board", "native"]
    assert cli.main(again) == 0


CAN_SCENARIO = """
[scenario]
sample_time = 0.02
[log]
path = "placeholder"
dbc = "car.dbc"
[log.columns]
a_m = "ACCEL.ACCEL_X"
omega_l = { column = "WHEEL_SPEEDS.WHEEL_SPEED_FL", radius = 0.25 }
omega_r = { column = "WHEEL_SPEEDS.WHEEL_SPEED_FR", radius = 0.25 }
brake = 0
[log.truth]
v = "WHEEL_SPEEDS.WHEEL_SPEED_FL"
[estimator]
name = "acc_kf"
[tolerance.v]
abs = 2e-4
rel = 1e-5
"""


@pytest.mark.parametrize("suffix", [".mf4", ".log", ".asc"])
def test_a_raw_can_log_replays_decoded_with_its_dbc(can_log, tmp_path, suffix) -> None:  # noqa: ANN001
    path, _ = can_log(suffix)
    sc = tmp_path / "can.toml"
    sc.write_text(CAN_SCENARIO)
    out = tmp_path / "run"
    args = ["replay", str(path), "--scenario", str(sc), "--board", "native", "--out", str(out)]
    assert cli.main(args) == 0
    md = (out / "report.md").read_text()
    row = "| omega_l | WHEEL_SPEEDS.WHEEL_SPEED_FL | / radius 0.25 m, (km/h)/m → rad/s | 100 Hz |"
    assert row in md
    assert "low-pass 20 Hz (Butterworth 4, zero phase), 100 → 50 Hz" in md
    assert "- the run starts where ACCEL.ACCEL_X starts (t = " in md  # ASC stamps from 0


def test_a_log_with_a_gap_is_refused_by_line_and_column(tmp_path, capsys) -> None:  # noqa: ANN001
    rows = [f"{k * 0.1:.1f},{k}" for k in range(100)] + [
        f"{k * 0.1:.1f},{k}" for k in range(150, 200)
    ]
    rows.insert(10, rows[10])  # a duplicated stamp: merged, and named in the report
    (tmp_path / "gap.csv").write_text("t [s],speed [1]\n" + "\n".join(rows))
    sc = tmp_path / "gap.toml"
    sc.write_text(
        '[scenario]\nsample_time = 0.1\n[log]\npath = "gap.csv"\n[log.columns]\ny = "speed"\n'
        '[estimator]\nname = "passthrough"\n[tolerance.y]\nrel = 1.2e-7\n'
    )
    args = ["replay", str(tmp_path / "gap.csv"), "--scenario", str(sc), "--board", "native"]
    assert cli.main(args) == 2
    err = capsys.readouterr()
    said = " ".join((err.out + err.err).split())
    assert "gap.csv: line 103, column speed: no value for 5.1 s (t = 9.9 to 15 s)" in said
    assert 'on_gap = "split"' in said
    sc.write_text(sc.read_text().replace("[log.columns]", 'on_gap = "split"\n[log.columns]'))
    out = tmp_path / "run"
    assert cli.main([*args, "--out", str(out)]) == 0
    printed = " ".join(capsys.readouterr().out.split())
    assert "log: split at 1 gaps longer than max_gap_s" in printed
    md = (out / "report.md").read_text()
    assert "1 duplicated stamps merged (mean), first at line 13, column speed" in md
    assert "- split at 1 gaps longer than max_gap_s: stretches 0-9.9 s, 15-19.9 s" in md


def test_a_recording_replayed_with_another_estimator_s_scenario_says_whose_it_is(
    built,  # noqa: ANN001
    tmp_path,  # noqa: ANN001
    capsys,  # noqa: ANN001
) -> None:
    short = tmp_path / "short.toml"
    sine = (DATA_ROOT / "scenarios/synthetic/sine.toml").read_text()
    short.write_text(sine.replace("duration = 20.0", "duration = 0.1"))
    assert cli.main(["run", str(short), "--board", "native", "--out", str(tmp_path / "r")]) == 0
    capsys.readouterr()
    args = ["replay", str(tmp_path / "r"), "--scenario", "braking/manf-hard-stop"]
    assert cli.main([*args, "--board", "native"]) == 2
    said = " ".join(capsys.readouterr().out.split())
    assert "no column 'omega_f'; columns: t, y, truth.y (a run of passthrough: replay it" in said


def test_a_log_replayed_with_a_scenario_that_maps_no_column_says_what_to_add(
    built,  # noqa: ANN001
    tmp_path,  # noqa: ANN001
    capsys,  # noqa: ANN001
) -> None:
    log = tmp_path / "drive.csv"
    log.write_text("t [s],speed [1]\n0,1\n0.1,2\n0.2,3\n")
    assert cli.main(["replay", str(log), "--scenario", "sine", "--board", "native"]) == 2
    said = " ".join(capsys.readouterr().out.split())
    assert "drive.csv: no column 'y'; columns: 't', 'speed' (sine.toml has no [log.columns]" in said


def test_a_closed_loop_s_recording_replays_open_loop_to_the_same_outputs(
    built,  # noqa: ANN001
    tmp_path,  # noqa: ANN001
    capsys,  # noqa: ANN001
) -> None:
    short = tmp_path / "s5.toml"
    s5 = (DATA_ROOT / "scenarios/eso/s5-iso-active-eso.toml").read_text()
    short.write_text(s5.replace("duration = 20.0", "duration = 0.5"))
    assert "closed_loop = true" in s5 and "duration = 20.0" in s5
    assert cli.main(["run", str(short), "--board", "native", "--out", str(tmp_path / "a")]) == 0
    again = ["replay", str(tmp_path / "a"), "--scenario", str(short), "--board", "native"]
    assert cli.main([*again, "--out", str(tmp_path / "b")]) == 0
    capsys.readouterr()
    assert cli.main(["compare", str(tmp_path / "a"), str(tmp_path / "b")]) == 0
    assert "same results" in capsys.readouterr().out
