"""Scenario files: every mistake is refused with the file, the key and what is allowed."""

import math

import numpy as np
import pytest

from vehil import scenario
from vehil.scenario import ScenarioError


def base() -> dict:
    return {
        "scenario": {"duration": 1.0, "sample_time": 0.01, "seed": 3},
        "plant": {"name": "noisy_sine", "amplitude": 1.5},
        "estimator": {"name": "passthrough", "mode": "F32"},
        "tolerance": {"y": {"abs": 1e-6, "truth_rms": 0.1}},
    }


def test_a_good_scenario_loads_with_defaults_filled_in() -> None:
    sc = scenario.parse(base(), "x.toml")
    assert sc.samples == 100
    assert sc.plant_params["amplitude"] == 1.5 and sc.plant_params["noise_std"] == 0.05
    assert sc.tolerances["y"].abs == 1e-6 and sc.tolerances["y"].truth_rms == 0.1
    assert sc.score_from_s == 0.0


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d["scenario"].update(durration=2), r"x.toml: scenario.durration: unknown key"),
        (lambda d: d["scenario"].update(sample_time=0), r"scenario.sample_time: 0 is outside"),
        (lambda d: d["scenario"].update(duration="long"), r"scenario.duration: must be a number"),
        (
            lambda d: d["estimator"].update(name="kalman"),
            r"estimator.name: no such estimator; known: .*passthrough",
        ),
        (
            lambda d: d["estimator"].update(mode="F64"),
            r"estimator.mode: 'F64' is not one of F32, FIXED",
        ),
        (
            lambda d: d["plant"].update(name="tractor"),
            r"plant.name: no such plant; known: .*noisy_sine",
        ),
        (
            lambda d: d["plant"].update(amplitude=-1),
            r"plant: amplitude = -1 is outside \[0, 1000\]",
        ),
        (lambda d: d["plant"].update(wheels=4), r"plant: plant noisy_sine has no parameter wheels"),
        (lambda d: d["tolerance"].update(v={"abs": 1}), r"tolerance.v: no output of that name"),
        (lambda d: d["tolerance"]["y"].update(abs=-1), r"tolerance.y.abs: -1 is outside"),
        (
            lambda d: d["tolerance"]["y"].update(bit_exact="yes"),
            r"bit_exact: must be true or false",
        ),
        (
            lambda d: d["tolerance"]["y"].update(from_samples=2.5),
            r"tolerance.y.from_samples: must be a whole number of samples",
        ),
        (lambda d: d.update(log={"path": "a.csv"}), r"give exactly one of \[plant\] and \[log\]"),
        (lambda d: d.update(extra={}), r"extra: unknown key; allowed here: scenario, plant"),
        (lambda d: d["scenario"].update(closed_loop="yes"), r"closed_loop: must be true or false"),
        (
            lambda d: d["scenario"].update(score_from_s=1.0),
            r"scenario.score_from_s: 1 s leaves nothing to score: the drive lasts 1 s",
        ),
        (lambda d: d["scenario"].update(score_from_s=-1), r"scenario.score_from_s: -1 is outside"),
        (lambda d: d["scenario"].update(seed=1.5), r"scenario.seed: must be a whole number, got"),
        (
            lambda d: d["tolerance"]["y"].update(from_s=5),
            r"tolerance.y.from_s: starts at 5 s, where the drive has ended \(1 s\): nothing",
        ),
        (
            lambda d: d["tolerance"]["y"].update(from_samples=100),
            r"tolerance.y.from_samples: starts at 1 s, where the drive has ended",
        ),
        (
            lambda d: d.update(signals={"y": "speed"}),
            r"signals.y = 'speed': plant noisy_sine measures no such signal; it gives y: map",
        ),
    ],
)
def test_mistakes_are_named(change, message) -> None:  # noqa: ANN001
    data = base()
    change(data)
    with pytest.raises(ScenarioError, match=message):
        scenario.parse(data, "x.toml")


def test_a_log_scenario_runs_to_the_end_of_the_log_unless_cut(tmp_path) -> None:  # noqa: ANN001
    data = base()
    del data["plant"]
    data["scenario"].pop("duration")
    data["log"] = {"path": "drive.csv", "columns": {"y": "speed"}}
    sc = scenario.parse(data, "x.toml", tmp_path / "x.toml")
    assert math.isinf(sc.duration)
    assert sc.log is not None and sc.log.path == tmp_path / "drive.csv"
    assert sc.log.columns == {"y": "speed"}
    data["log"]["columns"] = {"speed": "y"}
    with pytest.raises(ScenarioError, match=r"log.columns.speed: no estimator input of that name"):
        scenario.parse(data, "x.toml", tmp_path / "x.toml")


def test_every_shipped_scenario_loads() -> None:
    paths = scenario.shipped()
    assert paths
    for path in paths:
        scenario.load(path)


def test_a_scenario_is_found_by_name_or_refused_with_a_hint() -> None:
    assert scenario.find("sine").name == "sine.toml"
    with pytest.raises(ScenarioError, match="vehil scenarios"):
        scenario.find("no-such-scenario")
    with pytest.raises(
        ScenarioError, match=r"no scenario 'sien' \(did you mean synthetic/sine\?\)"
    ):
        scenario.find("sien")
    with pytest.raises(ScenarioError, match=r"\(did you mean braking/manf-hard-stop-fixed, "):
        scenario.find("braking/manf-hrd-stop-fixed")


def test_a_tolerance_from_a_time_on_leaves_the_start_unchecked() -> None:
    import numpy as np

    from vehil import compare

    data = base()
    data["tolerance"]["y"] = {"abs": 0.1, "from_s": 0.05}
    sc = scenario.parse(data, "x.toml")
    assert sc.tolerances["y"].from_s == 0.05
    n = 10
    board, ref = np.zeros((n, 1)), np.zeros((n, 1))
    series = compare.Series(
        names=["y"],
        units={"y": ""},
        t=np.arange(n) * 0.01,
        board=board,
        reference=ref,
        truth={},
        status=np.zeros(n, dtype=np.int64),
        cycles=np.zeros(n, dtype=np.int64),
        rtt_s=np.zeros(n),
        late=np.zeros(n, dtype=bool),
        tolerances=sc.tolerances,
    )
    board[2, 0] = 5.0  # at 0.02 s: not checked
    assert compare.evaluate(series).outputs["y"].reference.passed
    board[7, 0] = 5.0  # at 0.07 s
    verdict = compare.evaluate(series).outputs["y"].reference
    assert verdict.passed is False and verdict.outside_tolerance == 1


@pytest.mark.parametrize(
    ("log", "message"),
    [
        ({"path": "d.blf"}, r"log.dbc: a blf log holds raw CAN frames: name the DBC"),
        (
            {"path": "d.csv", "preset": "excel"},
            r"log.preset: 'excel' is not one of torque, asammdf",
        ),
        (
            {"path": "d.csv", "on_gap": "bridge"},
            r"log.on_gap: 'bridge' is not one of refuse, split",
        ),
        ({"path": "d.csv", "columns": {"y": True}}, r"log.columns.y: must be a column name"),
        ({"path": "d.csv", "columns": {"y": {"unit": "m"}}}, r"give exactly one of column and"),
        ({"path": "d.csv", "columns": {"y": {"column": "a", "gain": 2}}}, r"y.gain: unknown key"),
    ],
)
def test_log_mistakes_are_named(tmp_path, log, message) -> None:  # noqa: ANN001
    data = base()
    del data["plant"]
    data["log"] = log
    with pytest.raises(ScenarioError, match=message):
        scenario.parse(data, "x.toml", tmp_path / "x.toml")


def test_a_log_preset_a_dbc_and_derived_columns_are_read(tmp_path) -> None:  # noqa: ANN001
    data = base()
    del data["plant"]
    data["log"] = {
        "path": "drive.csv",
        "preset": "torque",
        "max_gap_s": 2.0,
        "columns": {"y": {"column": "Speed (OBD)", "unit": "km/h", "scale": 2}},
    }
    log = scenario.parse(data, "x.toml", tmp_path / "x.toml").log
    assert log is not None and (log.format, log.time) == ("csv", "Device Time")
    assert log.time_format == "%d-%b-%Y %H:%M:%S.%f" and log.max_gap_s == 2.0
    assert log.columns["y"] == scenario.ColumnMap(column="Speed (OBD)", unit="km/h", scale=2.0)
    data["log"] = {"path": "drive.asc", "dbc": "car.dbc", "columns": {"y": "d/dt WHEELS.FL"}}
    log = scenario.parse(data, "x.toml", tmp_path / "x.toml").log
    assert log is not None and log.format == "asc" and log.dbc == tmp_path / "car.dbc"
    assert scenario.ColumnMap.of(log.columns["y"]) == scenario.ColumnMap(
        column="WHEELS.FL", derivative=True
    )
    data["log"]["columns"] = {"y": 0}
    log = scenario.parse(data, "x.toml", tmp_path / "x.toml").log
    assert log is not None and log.columns["y"] == scenario.ColumnMap(value=0.0)


def test_a_regular_log_runs_at_its_own_rate(tmp_path) -> None:  # noqa: ANN001
    from vehil.logs import trace_from_log

    rng = np.random.default_rng(2)
    t = np.arange(300) * 0.02 + rng.uniform(-1e-4, 1e-4, 300)  # 50 Hz, stamps jitter 0.1 ms
    rows = "\n".join(f"{a:.6f},{k}" for k, a in enumerate(t))
    (tmp_path / "drive.csv").write_text("t [s],speed [1]\n" + rows)
    data = base()
    del data["plant"]
    data["scenario"].update(sample_time="log")
    data["scenario"].pop("duration")
    data["log"] = {"path": "drive.csv", "columns": {"y": "speed"}}
    sc = scenario.parse(data, "x.toml", tmp_path / "x.toml")
    assert sc.sample_time == pytest.approx(0.02, rel=1e-4)
    assert sc.log is not None
    trace = trace_from_log(sc.log, sc.estimator, sc.sample_time, sc.duration)
    np.testing.assert_array_equal(trace.signals["y"], np.arange(300))
    how = trace.timing[0]["resampling"]
    assert how.startswith("as logged (49.99 Hz, stamps within 0.1") and how.endswith("grid)")
    (tmp_path / "drive.csv").write_text("t [s],speed [1]\n0,0\n0.02,1\n0.05,2\n0.07,3\n")
    with pytest.raises(ScenarioError, match=r'sample_time: "log": .* the log has no one regular'):
        scenario.parse(data, "x.toml", tmp_path / "x.toml")


def test_parameters_an_estimator_s_rules_refuse_are_named_before_the_board_sees_them() -> None:
    d = base()
    d["estimator"] = {"name": "rls", "mode": "FIXED", "params": {"prefilter_hz": 5.0}}
    with pytest.raises(ScenarioError, match=r"estimator.params: rls in FIXED: prefilter_hz must"):
        scenario.parse(d, "x.toml")
