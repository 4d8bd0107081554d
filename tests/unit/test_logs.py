"""Recorded drives: columns, units and values are checked, and each problem is located."""

import math

import numpy as np
import pytest

from vehil import estimators
from vehil.logs import LogError, trace_from_log
from vehil.scenario import LogSource

SPEC = estimators.get("passthrough")


def log(path, **kw) -> LogSource:  # noqa: ANN001
    return LogSource(
        path=path,
        format="csv",
        time=kw.get("time", "t"),
        columns=kw.get("columns", {"y": "speed"}),
        truth=kw.get("truth", {}),
    )


def csv(tmp_path, text: str):  # noqa: ANN001, ANN201
    path = tmp_path / "drive.csv"
    path.write_text(text)
    return path


def test_a_csv_log_is_resampled_onto_the_sample_grid(tmp_path) -> None:  # noqa: ANN001
    path = csv(tmp_path, "t [s],speed [1],ref [1]\n0,0,0\n0.1,1,2\n0.2,2,4\n")
    trace = trace_from_log(log(path, truth={"y": "ref"}), SPEC, 0.05, math.inf)
    np.testing.assert_allclose(trace.t, [0, 0.05, 0.1, 0.15, 0.2])
    np.testing.assert_allclose(trace.signals["y"], [0, 0.5, 1, 1.5, 2])
    np.testing.assert_allclose(trace.truth["y"], [0, 1, 2, 3, 4])


@pytest.mark.parametrize(
    ("text", "kw", "message"),
    [
        ("t [s],v [1]\n0,1\n0.1,2\n", {}, r"no column 'speed' for input y; columns: t, v"),
        ("t [s],speed [km/h]\n0,1\n0.1,2\n", {}, r"column 'speed' is in 'km/h'; input y needs '1'"),
        (
            "t [s],speed\n0,1\n0.1,nan\n",
            {},
            r"line 3, column speed: nan is not a finite number \(1 such values",
        ),
        (
            "t [s],speed\n0,1\n0.1,2\n0.2\n",
            {},
            r"line 4 has 1 fields, the header 2 \(the file looks cut short\)",
        ),
        ("t [s],speed\n0,1\n0.1,fast\n", {}, r"line 3, column speed: 'fast' is not a number"),
        ("time,speed\n0,1\n0.1,2\n", {}, r"no time column 't'"),
        ("t,speed\n0,1\n0,2\n", {}, r"line 3, column t: time 0 does not increase on 0 before"),
        ("", {}, r"empty file"),
        ("t [s],[1]\n0,1\n", {}, r"line 1, column 2: header cell '\[1\]' is not"),
    ],
)
def test_bad_logs_are_refused_with_file_and_place(tmp_path, text, kw, message) -> None:  # noqa: ANN001
    path = csv(tmp_path, text)
    with pytest.raises(LogError, match=message) as exc:
        trace_from_log(log(path, **kw), SPEC, 0.05, math.inf)
    assert str(path) in str(exc.value)


def test_a_nan_and_a_time_step_back_are_named_by_the_file_line_and_column(tmp_path) -> None:  # noqa: ANN001
    rows = [f"{k * 0.1:.1f},{k}" for k in range(60)]
    rows[50] = "5.0,nan"  # sample 50: the file's line 52, after the header
    with pytest.raises(LogError, match=r"line 52, column speed: nan"):
        trace_from_log(log(csv(tmp_path, "t [s],speed\n" + "\n".join(rows))), SPEC, 0.1, 10)
    rows[50] = "4.9,50"  # time goes back on line 52
    with pytest.raises(LogError, match=r"line 52, column t: time 4.9 does not increase on 4.9"):
        trace_from_log(log(csv(tmp_path, "t [s],speed\n" + "\n".join(rows))), SPEC, 0.1, 10)


def test_an_mdf4_log_gives_its_channels_with_their_units(tmp_path) -> None:  # noqa: ANN001
    from asammdf import MDF, Signal

    t = np.arange(0, 1, 0.01)
    mdf = MDF(version="4.10")
    mdf.append([Signal(np.sin(t), t, name="speed", unit="1"), Signal(t, t, name="odo", unit="m")])
    path = tmp_path / "drive.mf4"
    mdf.save(path, overwrite=True)
    source = LogSource(path=path, format="mdf4", time="t", columns={"y": "speed"}, truth={})
    trace = trace_from_log(source, SPEC, 0.02, math.inf)
    assert len(trace) == 50
    np.testing.assert_allclose(trace.signals["y"], np.sin(np.arange(50) * 0.02), atol=1e-12)
    wrong_unit = LogSource(path=path, format="mdf4", time="t", columns={"y": "odo"}, truth={})
    with pytest.raises(LogError, match="column 'odo' is in 'm'; input y needs '1'"):
        trace_from_log(wrong_unit, SPEC, 0.02, math.inf)
    missing = LogSource(path=path, format="mdf4", time="t", columns={"y": "rpm"}, truth={})
    with pytest.raises(LogError, match="no channel 'rpm'"):
        trace_from_log(missing, SPEC, 0.02, math.inf)
