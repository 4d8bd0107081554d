"""Recorded drives: units converted or refused, each channel cleaned and resampled on its
own, gaps and edges handled, raw CAN decoded with a DBC; each problem is located."""

import gc
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from vehil import estimators
from vehil.logs import LogError, trace_from_log
from vehil.scenario import ColumnMap, LogSource

SPEC = estimators.get("passthrough")
ACC = estimators.get("acc_kf")


def log(path, **kw) -> LogSource:  # noqa: ANN001
    return LogSource(
        path=path,
        format=kw.pop("format", "csv"),
        time=kw.pop("time", "t"),
        columns=kw.pop("columns", {"y": "speed"}),
        truth=kw.pop("truth", {}),
        **kw,
    )


def csv(tmp_path, text: str, name: str = "drive.csv") -> Path:  # noqa: ANN001
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_csv_log_is_resampled_onto_the_sample_grid(tmp_path) -> None:  # noqa: ANN001
    path = csv(tmp_path, "t [s],speed [1],ref [1]\n0,0,0\n0.1,1,2\n0.2,2,4\n")
    trace = trace_from_log(log(path, truth={"y": "ref"}), SPEC, 0.05, math.inf)
    np.testing.assert_allclose(trace.t, [0, 0.05, 0.1, 0.15, 0.2])
    np.testing.assert_allclose(trace.signals["y"], [0, 0.5, 1, 1.5, 2])
    np.testing.assert_allclose(trace.truth["y"], [0, 1, 2, 3, 4])
    assert trace.timing[0]["resampling"] == "linear interpolation 10 → 20 Hz"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("t [s],v [1]\n0,1\n0.1,2\n", r"no column 'speed'; columns: 't', 'v'"),
        (
            "t [s],speed [m]\n0,1\n0.1,2\n",
            r"column 'speed' for input y: 'm' does not convert to '1'",
        ),
        ("t [s],speed\n0,1\n0.1,2\n", r"column 'speed' for input y: it has no unit; input y needs"),
        ("t [s],speed [furlong/fortnite]\n0,1\n0.1,2\n", r"its unit 'furlong/fortnite' is not one"),
        (
            "t [s],speed [1]\n0,1\n0.1,2\n0.2\n",
            r"line 4 has 1 fields, the header 2 \(the file looks",
        ),
        (
            "t [s],speed [1]\n0,1\n0.1,2,5\n",
            r"line 3 has 3 fields, the header 2: a value with an unquoted comma \(a decimal",
        ),
        ("t [s],speed [1]\n0,1\n0.1,fast\n", r"line 3, column speed: 'fast' is not a number"),
        ("t [s],speed [1]\n0,1\n0.1,inf\n", r"line 3, column speed: inf is not a finite number"),
        (
            "time [s],speed [1]\n0,1\n0.1,2\n",
            r"no time column 't' \(set \[log\] time, or a preset\); columns: 'time', 'speed'",
        ),
        ("t,speed [1]\n0,1\n0.1,2\n", r"time column 't' has no unit: write it in the header"),
        ("t [s],speed [1]\n0,1\n0.2,2\n0.1,3\n", r"line 4, column speed: time 0.1 s goes back"),
        ("t [s],speed [1]\n0,1\n-,2\n", r"column speed has 1 samples with a value"),
        ("", r"empty file"),
    ],
)
def test_bad_logs_are_refused_with_file_and_place(tmp_path, text, message) -> None:  # noqa: ANN001
    path = csv(tmp_path, text)
    with pytest.raises(LogError, match=message) as exc:
        trace_from_log(log(path), SPEC, 0.05, math.inf)
    assert str(path) in str(exc.value)


def acc_columns(**over) -> dict:  # noqa: ANN003
    cols = {
        "a_m": "Acceleration Sensor(X axis)",
        "omega_l": ColumnMap(column="Speed (OBD)", radius=0.3),
        "omega_r": ColumnMap(column="Speed (OBD)", radius=0.3),
        "brake": ColumnMap(value=0.0),
    }
    return {**cols, **over}


def test_an_obd_app_export_runs_with_its_units_converted(torque_log) -> None:  # noqa: ANN001
    source = log(
        torque_log,
        time="Device Time",
        time_format="%d-%b-%Y %H:%M:%S.%f",
        columns=acc_columns(),
        truth={"v": "Speed (OBD)"},
    )
    trace = trace_from_log(source, ACC, 0.1, math.inf)
    np.testing.assert_allclose(trace.truth["v"], 10 + 0.1 * trace.t, atol=1e-4)
    np.testing.assert_allclose(trace.signals["omega_l"], trace.truth["v"] / 0.3, atol=1e-9)
    np.testing.assert_allclose(trace.signals["a_m"], 0.1, atol=1e-5)
    assert np.all(trace.signals["brake"] == 0) and len(trace) > 1900
    rows = {r["input"]: r for r in trace.timing}
    assert rows["omega_l"]["unit"] == "/ radius 0.3 m, (km/h)/m → rad/s"
    assert rows["a_m"]["unit"] == "g → m/s^2"
    assert rows["brake"]["source"] == "constant 0"
    assert rows["omega_l"]["missing"] == "12"  # the `-` cells of that column alone
    assert rows["omega_l"]["resampling"].startswith("linear interpolation 0.96")


def test_a_column_with_no_unit_runs_once_the_scenario_states_it(tmp_path) -> None:  # noqa: ANN001
    path = csv(tmp_path, "t [s],speed\n0,0\n0.1,36\n0.2,72\n")
    with pytest.raises(
        LogError, match=r'state the column\'s unit in the scenario: \{ column = "speed"'
    ):
        trace_from_log(log(path), SPEC, 0.1, 1)
    stated = {"y": ColumnMap(column="speed", unit="1", scale=2.0, offset=1.0)}
    trace = trace_from_log(log(path, columns=stated), SPEC, 0.1, math.inf)
    np.testing.assert_allclose(trace.signals["y"], [1, 73, 145])
    assert trace.timing[0]["unit"] == "× 2 + 1"


def test_a_gap_is_refused_where_it_is_or_split_off(tmp_path) -> None:  # noqa: ANN001
    t = np.r_[np.arange(0, 20, 0.1), np.arange(30, 45, 0.1)]
    text = "t [s],speed [1]\n" + "\n".join(f"{x:.1f},{x:.3f}" for x in t)
    path = csv(tmp_path, text)
    with pytest.raises(
        LogError,
        match=r"line 202, column speed: no value for 10.1 s \(t = 19.9 to 30 s\), past the 0.5 s",
    ):
        trace_from_log(log(path), SPEC, 0.1, math.inf)
    split = trace_from_log(log(path, on_gap="split"), SPEC, 0.1, math.inf)
    assert split.t[-1] == pytest.approx(19.9) and split.signals["y"][0] == 0.0
    assert "split at 1 gaps longer than max_gap_s: stretches 0-19.9 s, 30-44.9 s" in split.notes[0]
    assert split.timing[0]["gaps"] == "none over 0.5 s"
    bridged = trace_from_log(log(path, max_gap_s=11.0), SPEC, 0.1, math.inf)
    assert bridged.t[-1] == pytest.approx(44.9)
    assert bridged.timing[0]["gaps"] == "none over 11 s"


def test_duplicated_stamps_are_merged_and_the_first_is_named(tmp_path) -> None:  # noqa: ANN001
    text = "t [s],speed [1]\n0,0\n0.1,1\n0.1,3\n0.2,4\n0.3,5\n0.3,7\n"
    trace = trace_from_log(log(csv(tmp_path, text)), SPEC, 0.1, math.inf)
    np.testing.assert_allclose(trace.signals["y"], [0, 2, 4, 6])
    assert trace.timing[0]["duplicates"] == (
        "2 duplicated stamps merged (mean), first at line 4, column speed"
    )
    assert trace.timing[0]["resampling"] == "as logged (10 Hz)"


def test_the_run_ends_where_the_first_input_ends(tmp_path) -> None:  # noqa: ANN001
    rows = [f"{k * 0.1:.1f},{k},{k if k <= 200 else '-'}" for k in range(600)]
    path = csv(tmp_path, "t [s],a [1],b [1]\n" + "\n".join(rows))
    trace = trace_from_log(log(path, truth={"y": "b"}, columns={"y": "a"}), SPEC, 0.1, math.inf)
    assert trace.t[-1] == pytest.approx(20.0)
    assert trace.notes == ["the run ends where b ends (t = 20 s; the log goes on to 59.9 s)"]


def test_a_fast_channel_is_low_passed_before_it_is_decimated(tmp_path) -> None:  # noqa: ANN001
    t = np.arange(0, 20, 1 / 83)  # 83 Hz: a 1 Hz signal and 37 Hz noise, aliased at 10 Hz
    x = np.sin(2 * np.pi * t) + np.sin(2 * np.pi * 37 * t)
    path = csv(
        tmp_path,
        "t [s],speed [1]\n" + "\n".join(f"{a:.6f},{b:.6f}" for a, b in zip(t, x, strict=True)),
    )
    trace = trace_from_log(log(path), SPEC, 0.1, math.inf)
    err = trace.signals["y"] - np.sin(2 * np.pi * (trace.t + t[0]))
    assert np.sqrt(np.mean(err[20:-20] ** 2)) < 0.05  # aliased, the 37 Hz would give 0.7
    assert trace.timing[0]["resampling"].startswith("low-pass 4 Hz (Butterworth 4, zero phase), 83")


def test_a_derivative_is_filtered_and_in_the_wanted_unit(tmp_path) -> None:  # noqa: ANN001
    t = np.arange(0, 10, 0.01)
    rng = np.random.default_rng(1)
    kmh = 3.6 * (5 + 0.5 * t**2 / 2) + rng.normal(0, 0.05, len(t))  # a = 0.5 t m/s²
    path = csv(
        tmp_path,
        "t [s],Speed [km/h]\n" + "\n".join(f"{a:.2f},{b:.4f}" for a, b in zip(t, kmh, strict=True)),
    )
    cols = {
        "a_m": ColumnMap.of("d/dt Speed"),
        "omega_l": ColumnMap(value=1.0),
        "omega_r": ColumnMap(value=1.0),
        "brake": ColumnMap(value=0.0),
    }
    trace = trace_from_log(log(path, columns=cols), ACC, 0.01, math.inf)
    a = trace.signals["a_m"][100:-100]
    np.testing.assert_allclose(a, 0.5 * trace.t[100:-100], atol=0.1)  # raw: ~1 m/s² noise
    assert {r["input"]: r["unit"] for r in trace.timing}["a_m"] == (
        "d/dt low-passed at 2 Hz, (km/h)/s → m/s^2"
    )


def test_an_asammdf_csv_export_reads_its_units_row(tmp_path) -> None:  # noqa: ANN001
    from asammdf import MDF, Signal

    t = np.arange(0, 2, 0.01)
    mdf = MDF(version="4.10")
    mdf.append([Signal(3.6 * t, t, name="speed", unit="km/h")])
    mdf.export("csv", tmp_path / "drive.csv", add_units=True)
    path = next(tmp_path.glob("drive*.csv"))
    cols = {"a_m": 0.0, "omega_l": ColumnMap(column="speed", radius=0.5), "omega_r": 2.0}
    source = log(path, time="timestamps", units_row=True, columns=cols | {"brake": 0.0})
    trace = trace_from_log(
        LogSource(
            **{
                **source.__dict__,
                "columns": {
                    k: v if isinstance(v, ColumnMap) else ColumnMap(value=v)
                    for k, v in cols.items()
                }
                | {"brake": ColumnMap(value=0.0)},
            }
        ),
        ACC,
        0.01,
        math.inf,
    )
    np.testing.assert_allclose(trace.signals["omega_l"], 2 * trace.t, atol=1e-9)


def test_an_mdf4_log_gives_its_channels_with_their_units(tmp_path) -> None:  # noqa: ANN001
    from asammdf import MDF, Signal

    t = np.arange(0, 1, 0.01)
    mdf = MDF(version="4.10")
    mdf.append([Signal(np.sin(t), t, name="speed", unit="1"), Signal(t, t, name="odo", unit="m")])
    path = tmp_path / "drive.mf4"
    mdf.save(path, overwrite=True)
    trace = trace_from_log(log(path, format="mdf4"), SPEC, 0.02, math.inf)
    assert len(trace) == 50
    np.testing.assert_allclose(trace.signals["y"], np.sin(np.arange(50) * 0.02), atol=1e-5)
    assert trace.timing[0]["resampling"].startswith("low-pass 20 Hz")
    same_rate = trace_from_log(log(path, format="mdf4"), SPEC, 0.01, math.inf)
    np.testing.assert_array_equal(same_rate.signals["y"], np.sin(t))
    with pytest.raises(LogError, match="column 'odo' for input y: 'm' does not convert to '1'"):
        trace_from_log(log(path, format="mdf4", columns={"y": "odo"}), SPEC, 0.02, math.inf)
    with pytest.raises(LogError, match="no channel 'rpm'"):
        trace_from_log(log(path, format="mdf4", columns={"y": "rpm"}), SPEC, 0.02, math.inf)


def test_a_cut_mdf4_file_is_refused_with_no_traceback_after_the_error(tmp_path) -> None:  # noqa: ANN001
    from asammdf import MDF, Signal

    t = np.arange(0, 1, 0.01)
    mdf = MDF(version="4.10")
    mdf.append([Signal(np.sin(t), t, name="speed", unit="1")])
    whole = tmp_path / "whole.mf4"
    mdf.save(whole, overwrite=True)
    path = tmp_path / "drive.mf4"
    path.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    unraisable: list = []
    hook, sys.unraisablehook = sys.unraisablehook, unraisable.append
    try:
        with pytest.raises(LogError, match="drive.mf4: not a readable MDF file"):
            trace_from_log(log(path, format="mdf4"), SPEC, 0.02, math.inf)
        gc.collect()
    finally:
        sys.unraisablehook = hook
    assert unraisable == []  # asammdf's half-built reader, collected quietly


@pytest.mark.parametrize(
    ("suffix", "fmt"), [(".mf4", "mdf4"), (".blf", "blf"), (".asc", "asc"), (".log", "candump")]
)
def test_raw_can_is_decoded_with_the_dbc(can_log, suffix, fmt) -> None:  # noqa: ANN001
    path, dbc = can_log(suffix)
    cols = {
        "a_m": "ACCEL.ACCEL_X",
        "omega_l": ColumnMap(column="WHEEL_SPEEDS.WHEEL_SPEED_FL", radius=0.25),
        "omega_r": ColumnMap(column="WHEEL_SPEEDS.WHEEL_SPEED_FR", radius=0.25),
        "brake": ColumnMap(value=0.0),
    }
    source = log(
        path, format=fmt, dbc=dbc, columns=cols, truth={"v": "WHEEL_SPEEDS.WHEEL_SPEED_FL"}
    )
    trace = trace_from_log(source, ACC, 0.02, math.inf)
    t_log = trace.t + 0.003  # the run starts at the first ACCEL frame
    np.testing.assert_allclose(trace.truth["v"], 10 + 0.5 * t_log, atol=0.01)
    np.testing.assert_allclose(trace.signals["omega_l"], trace.truth["v"] / 0.25, atol=1e-9)
    np.testing.assert_allclose(trace.signals["a_m"], 0.5, atol=1e-3)
    rows = {r["input"]: r for r in trace.timing}
    assert rows["omega_l"]["unit"] == "/ radius 0.25 m, (km/h)/m → rad/s"
    assert rows["omega_l"]["rate"] == "100 Hz" and rows["a_m"]["rate"] == "50 Hz"
    bad = log(path, format=fmt, dbc=dbc, columns={**cols, "a_m": "ACCEL.ACCEL_Y"})
    with pytest.raises(LogError, match=r"'ACCEL.ACCEL_Y' is not a MESSAGE.SIGNAL of car.dbc"):
        trace_from_log(bad, ACC, 0.02, math.inf)
    if fmt == "mdf4":  # bus logging read without its DBC: the hint says so
        with pytest.raises(LogError, match=r"CAN_DataFrame.*set \[log\] dbc and map MESSAGE"):
            trace_from_log(log(path, format=fmt, columns=cols), ACC, 0.02, math.inf)


def test_a_cut_blf_log_is_refused_not_run_as_the_whole_drive(can_log) -> None:  # noqa: ANN001
    path, dbc = can_log(".blf")
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    cols = {"y": ColumnMap(column="WHEEL_SPEEDS.WHEEL_SPEED_FL", unit="1")}
    with pytest.raises(LogError, match=r"drive.blf: the file is cut short: its header says "):
        trace_from_log(log(path, format="blf", dbc=dbc, columns=cols), SPEC, 0.02, math.inf)


def test_one_drive_through_csv_and_through_mdf4_gives_the_same_inputs(tmp_path) -> None:  # noqa: ANN001
    from asammdf import MDF, Signal

    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.008, 0.016, 2000))  # ~83 Hz, in bursts
    x = np.sin(t) + rng.normal(0, 0.1, len(t))
    text = "t [s],speed [1]\n" + "\n".join(f"{a:.17g},{b:.17g}" for a, b in zip(t, x, strict=True))
    path = csv(tmp_path, text)
    mdf = MDF(version="4.10")
    mdf.append([Signal(x, t, name="speed", unit="1")])
    mdf.save(tmp_path / "drive.mf4", overwrite=True)
    a = trace_from_log(log(path), SPEC, 0.1, math.inf)
    b = trace_from_log(log(tmp_path / "drive.mf4", format="mdf4"), SPEC, 0.1, math.inf)
    np.testing.assert_array_equal(a.signals["y"], b.signals["y"])


def test_a_logger_spelling_stays_itself_under_a_derivative_or_a_radius() -> None:
    from vehil import units

    one = np.array([1.0])
    np.testing.assert_allclose(units.convert(one, "g", "m/s^2"), 9.80665)
    np.testing.assert_allclose(units.convert(one, "g", "m/s^3", per="s"), 9.80665)  # not gram/s
    np.testing.assert_allclose(units.convert(one, "kmh", "rad/s", per="m"), 1 / 3.6)
    np.testing.assert_allclose(units.convert(one, "rpm", "rad/s"), 2 * np.pi / 60)
    np.testing.assert_allclose(units.convert(one, "Meters/second", "m/s"), 1.0)
    assert units.same("m/s²", "m/s^2") and not units.known("furlong/fortnite")
    with pytest.raises(units.UnitError, match="'g' does not convert to 'm/s'"):
        units.convert(one, "g", "m/s")


PLAIN = "t [s],speed [1]\n0,1.5\n0.1,2.5\n0.2,-3.25\n0.3,4e-1\n"


@pytest.mark.parametrize(
    "data",
    [
        # Excel in a German or French locale: `;`, decimal commas, CRLF, its BOM
        "\ufefft [s];speed [1]\r\n0;1,5\r\n0,1;2,5\r\n0,2;-3,25\r\n0,3;4e-1\r\n".encode(),
        # ... with Excel's `sep=` line, and blank lines at the end
        b"sep=;\nt [s];speed [1]\n0;1,5\n0,1;2,5\n0,2;-3,25\n0,3;0,4\n\n\n",
        # comma-separated with the decimal commas quoted; a trailing delimiter
        b't [s],speed [1],\n"0","1,5",\n"0,1","2,5",\n"0,2","-3,25",\n"0,3","0,4",\n',
        # tab-separated, as Excel's "Unicode text": UTF-16 with its BOM
        "t [s]\tspeed [1]\r\n0\t1.5\r\n0.1\t2.5\r\n0.2\t-3.25\r\n0.3\t0.4\r\n".encode("utf-16"),
        # a row of units under the header, bracketed or not, found as such
        b"t,speed\n[s],[1]\n0,1.5\n0.1,2.5\n0.2,-3.25\n0.3,0.4\n",
        b"t;speed\nms;1\n0;1,5\n100;2,5\n200;-3,25\n300;0,4\n",
        # time of day, with a decimal comma, across midnight
        b"t;speed [1]\n23:59:59,9;1,5\n00:00:00,0;2,5\n00:00:00,1;-3,25\n00:00:00,2;0,4\n",
    ],
    ids=["de-excel", "sep-line", "quoted", "utf16-tab", "units-row", "units-row-ms", "midnight"],
)
def test_real_loggers_exports_read_as_the_plain_csv(tmp_path, data: bytes) -> None:  # noqa: ANN001
    plain = trace_from_log(log(csv(tmp_path, PLAIN, "plain.csv")), SPEC, 0.1, math.inf)
    path = tmp_path / "drive.csv"
    path.write_bytes(data)
    got = trace_from_log(log(path), SPEC, 0.1, math.inf)
    np.testing.assert_allclose(got.t, plain.t, atol=1e-9)
    np.testing.assert_allclose(got.signals["y"], plain.signals["y"], atol=1e-9)


def test_a_windows_ansi_export_keeps_its_degree_sign(tmp_path) -> None:  # noqa: ANN001
    from vehil.csvlog import read_columns

    path = tmp_path / "drive.csv"
    path.write_bytes("t [s];yaw rate [°/s]\n0;1,5\n0,1;2\n".encode("cp1252"))
    cols = read_columns(path, ["yaw rate"], "t")
    assert cols.units == {"yaw rate": "°/s"}
    np.testing.assert_allclose(cols.values["yaw rate"], [1.5, 2.0])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "t [s];a,b [1]\n0,1;2\n0,2;3\n",
            r"line 1: the header splits by ',' into 2 and by ';' into 2 columns, and the first "
            r'rows split alike by each: say which delimiter the file uses: \[log\] delimiter = ";"',
        ),
        (
            "t [s];speed [1]\n0;1,5\n0.1;2\n",
            r"numbers with a decimal comma \(line 2, column speed \[1\]: '1,5'\) and with a "
            r"decimal point \(line 3, column t \[s\]: '0.1'\): export the file again",
        ),
        (
            "t [s];speed [1]\n1;1,250\n2;2,500\n",
            r"line 2, column speed \[1\]: '1,250' is 1.250 with a decimal comma or 1250 with a "
            r'thousands separator, and no other number says which: set \[log\] decimal = ","',
        ),
        (
            "t [s];speed [1]\n0;1,5\n0,1;1.250,5\n",
            r"line 3, column speed: '1.250,5' is not a number in this file, whose decimal sign "
            r"is ','",
        ),
    ],
    ids=["delimiter", "mixed-decimals", "thousands-or-decimal", "grouped"],
)
def test_a_csv_whose_delimiter_or_decimal_sign_is_open_is_refused_saying_what_to_set(
    tmp_path,  # noqa: ANN001
    text: str,
    message: str,
) -> None:
    path = csv(tmp_path, text)
    with pytest.raises(LogError, match=message):
        trace_from_log(log(path, columns={"y": "speed"}), SPEC, 1.0, math.inf)


def test_the_scenario_settles_a_delimiter_or_decimal_sign_the_file_leaves_open(tmp_path) -> None:  # noqa: ANN001
    path = csv(tmp_path, "t [s];speed [1]\n1;1,250\n2;2,500\n")
    trace = trace_from_log(log(path, decimal=","), SPEC, 1.0, math.inf)
    np.testing.assert_allclose(trace.signals["y"], [1.25, 2.5])
    path = csv(tmp_path, "t [s];a,b [1]\n0;1\n1;2\n")
    trace = trace_from_log(log(path, delimiter=";", columns={"y": "a,b"}), SPEC, 1.0, math.inf)
    np.testing.assert_allclose(trace.signals["y"], [1, 2])


def test_stamps_a_little_out_of_order_are_sorted_and_a_restart_refused(tmp_path) -> None:  # noqa: ANN001
    # two buses interleaved by the logger: 0.23 comes in before 0.2
    text = "t [s],speed [1]\n0,0\n0.1,1\n0.23,2.3\n0.2,2\n0.3,3\n0.4,4\n"
    trace = trace_from_log(log(csv(tmp_path, text)), SPEC, 0.1, math.inf)
    np.testing.assert_allclose(trace.signals["y"], [0, 1, 2, 3, 4], atol=1e-9)
    assert (
        trace.timing[0]["duplicates"]
        == "1 stamps out of order sorted, first at line 5, column speed"
    )
    restarted = "t [s],speed [1]\n" + "".join(f"{k % 30 * 0.1:.1f},{k}\n" for k in range(50))
    with pytest.raises(
        LogError,
        match=r"line 32, column speed: time 0 s goes back from 2.9 s before it, half a step or "
        r"more \(1 such steps\): .* cut the log where its time starts again",
    ):
        trace_from_log(log(csv(tmp_path, restarted)), SPEC, 0.1, math.inf)


def test_epoch_stamps_are_named_to_the_ms_in_messages_and_the_report(tmp_path) -> None:  # noqa: ANN001
    t = 1_700_000_000 + np.r_[np.arange(0, 20, 0.1), np.arange(30, 35, 0.1)]
    text = "t [s],speed [1]\n" + "".join(f"{x:.1f},1\n" for x in t)
    path = csv(tmp_path, text)
    with pytest.raises(LogError, match=r"\(t = 1700000019.9 to 1700000030 s\)"):
        trace_from_log(log(path), SPEC, 0.1, math.inf)
    split = trace_from_log(log(path, on_gap="split"), SPEC, 0.1, math.inf)
    assert split.timing[0]["logged"] == "1700000000-1700000019.9 s"
