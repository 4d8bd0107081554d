"""Scenario files: every mistake is refused with the file, the key and what is allowed."""

import math

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
            r"plant: amplitude = -1 1 is outside \[0, 1000\]",
        ),
        (lambda d: d["plant"].update(wheels=4), r"plant: plant noisy_sine has no parameter wheels"),
        (lambda d: d["tolerance"].update(v={"abs": 1}), r"tolerance.v: no output of that name"),
        (lambda d: d["tolerance"]["y"].update(abs=-1), r"tolerance.y.abs: -1 is outside"),
        (
            lambda d: d["tolerance"]["y"].update(bit_exact="yes"),
            r"bit_exact: must be true or false",
        ),
        (lambda d: d.update(log={"path": "a.csv"}), r"give exactly one of \[plant\] and \[log\]"),
        (lambda d: d.update(extra={}), r"extra: unknown key; allowed here: scenario, plant"),
        (lambda d: d["scenario"].update(closed_loop="yes"), r"closed_loop: must be true or false"),
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
