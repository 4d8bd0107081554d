"""Recordings read back whole, and a file cut short reads back up to its last batch."""

import numpy as np
import pytest

from vehil import record


def write(path, rows: int, *, close: bool = True) -> None:  # noqa: ANN001
    schema = record.columns(["u"], ["y"], ["y"])
    rec = record.Recorder(
        path,
        schema,
        {
            "estimator": {
                "inputs": [{"name": "u", "unit": "m/s", "q": 16}],
                "outputs": [{"name": "y", "unit": "m", "q": 16}],
            }
        },
    )
    for k in range(rows):
        rec.append(
            {
                "k": k,
                "t": k * 0.01,
                "in.u": k * 1.0,
                "truth.y": -k,
                "ref.y": 2.0 * k,
                "board.y": 2.0 * k + 1e-7,
                "status": 0,
                "cycles": 100 + k,
                "rtt_s": 1e-3,
                "late": False,
            }
        )
    if close:
        rec.close({"ended": "completed"})
    else:
        rec.flush()


def test_a_recording_reads_back_with_its_header_and_end(tmp_path) -> None:  # noqa: ANN001
    path = tmp_path / "run.arrow"
    write(path, 2500)
    rec = record.read(path)
    assert len(rec) == 2500 and rec.truncated is None
    assert rec.end["ended"] == "completed" and rec.end["samples"] == 2500
    assert rec.units == {"u": "m/s", "y": "m"}
    assert rec.header["host"]["python"]
    np.testing.assert_array_equal(rec.data["cycles"], np.arange(2500) + 100)


def test_a_file_cut_short_keeps_every_whole_batch(tmp_path) -> None:  # noqa: ANN001
    path = tmp_path / "run.arrow"
    write(path, 2500)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) - 400])  # into the last data batch or the end record
    rec = record.read(path)
    assert rec.truncated is not None
    assert len(rec) in (2000, 2500)
    np.testing.assert_array_equal(rec.data["k"], np.arange(len(rec)))


def test_a_run_that_never_closed_says_so(tmp_path) -> None:  # noqa: ANN001
    path = tmp_path / "run.arrow"
    write(path, 1500, close=False)
    rec = record.read(path)
    assert len(rec) == 1500 and rec.end is None
    assert "did not finish" in rec.truncated


def test_other_files_are_refused_by_name(tmp_path) -> None:  # noqa: ANN001
    path = tmp_path / "notes.arrow"
    path.write_text("hello")
    with pytest.raises(record.RecordingError, match="notes.arrow: not a vehil recording"):
        record.read(path)


def test_once_conversions_are_loaded_a_first_batch_loads_no_module(tmp_path) -> None:  # noqa: ANN001
    """pyarrow imports pandas on its first array made from Python values (0.15-0.5 s): in
    a fresh interpreter, once record.load_conversions() has run (vehil.runner does before
    a run starts), the first flush, in the middle of a real-time run, loads no module."""
    import subprocess
    import sys

    script = f"""
import sys
from vehil import record
record.load_conversions()
schema = record.columns(["u"], ["y"], ["y"])
rec = record.Recorder(__import__("pathlib").Path({str(tmp_path / "r.arrow")!r}), schema, {{}})
before = set(sys.modules)
rec.append({{"k": 0, "t": 0.0, "in.u": 1.0, "truth.y": 0.0, "ref.y": 0.0, "board.y": 0.0,
            "status": 0, "cycles": 1, "rtt_s": 1e-3, "late": False}})
rec.flush()
print(sorted(set(sys.modules) - before))
"""
    out = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True
    ).stdout
    assert out.strip() == "[]"


def test_a_recording_that_is_not_there_is_named_as_missing(tmp_path) -> None:  # noqa: ANN001
    with pytest.raises(record.RecordingError, match=r"none.arrow: no such recording \(give a"):
        record.read(tmp_path / "none.arrow")
    with pytest.raises(record.RecordingError, match=r": no such recording"):
        record.read(tmp_path)  # a folder with no run.arrow in it, given as the file


def test_a_recording_cut_in_its_header_says_so(tmp_path) -> None:  # noqa: ANN001
    path = tmp_path / "run.arrow"
    write(path, 10)
    path.write_bytes(path.read_bytes()[:100])
    with pytest.raises(record.RecordingError, match=r"cut short in its header, before any sample"):
        record.read(path)
    path.write_text("t,y\n0,1\n")
    with pytest.raises(record.RecordingError, match=r"run.arrow: not a vehil recording"):
        record.read(path)
