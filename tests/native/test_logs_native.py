"""An OBD app's export replayed through the CLI: converted, the conversions in the report;
the recording it gives replays by name, whatever the scenario's [log] maps."""

import pytest

from vehil import cli, record

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
