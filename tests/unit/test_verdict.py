"""One verdict, computed once: every check says whether it ran, and a run that did not
complete, or checked nothing, never reads PASS in the console, report.md or figures.json."""

import dataclasses
import json
import signal

import numpy as np
import pytest
from rich.console import Console

from vehil import compare, report
from vehil.protocol.schema import SCHEMA
from vehil.scenario import Tolerance


def series(board, ref, tolerances, **kw) -> compare.Series:  # noqa: ANN001
    board = np.asarray(board, dtype=float)
    board = board if board.ndim == 2 else board.reshape(-1, 1)
    ref = np.asarray(ref, dtype=float).reshape(board.shape)
    n, m = board.shape
    names = kw.pop("names", ["y", "m"][:m])
    return compare.Series(
        names=names,
        units={name: "" for name in names},
        t=np.arange(n) * 0.01,
        board=board,
        reference=ref,
        truth=kw.pop("truth", {}),
        status=np.zeros(n, dtype=np.uint8),
        cycles=np.full(n, 100, dtype=np.int64),
        rtt_s=np.full(n, 1e-3),
        late=np.zeros(n, dtype=bool),
        tolerances=tolerances,
        **kw,
    )


def written(s: compare.Series, tmp_path) -> tuple[str, dict, compare.Figures]:  # noqa: ANN001
    figures = compare.evaluate(s)
    md = report.write(s, figures, {"title": "t"}, tmp_path).read_text()
    return md, json.loads((tmp_path / "figures.json").read_text()), figures


def row(md: str, name: str) -> str:
    return next(line for line in md.splitlines() if line.startswith(f"| {name} "))


def console_text(figures: compare.Figures) -> str:
    c = Console(width=200, record=True)
    c.print(report.summary_table(figures, "t"))
    c.print(report.verdict_line(figures))
    return c.export_text()


def test_report_md_fails_an_output_that_fails_only_against_the_truth(tmp_path) -> None:  # noqa: ANN001
    n = 50
    s = series(
        np.ones(n), np.ones(n), {"y": Tolerance(abs=0.1, truth_rms=0.01)}, truth={"y": np.zeros(n)}
    )
    md, data, figures = written(s, tmp_path)
    assert "FAIL truth" in row(md, "y") and "Overall: **FAIL**" in md
    assert data["pass"] is False and data["outputs"]["y"]["passed"] is False
    assert data["outputs"]["y"]["truth"]["passed"] is False
    assert "FAIL truth" in console_text(figures) and figures.verdict.exit_status == 1


def test_an_output_without_tolerance_is_not_checked_however_far_off(tmp_path) -> None:  # noqa: ANN001
    n = 50
    board = np.column_stack([np.ones(n), np.full(n, 1509.5)])
    ref = np.column_stack([np.ones(n), np.full(n, 1500.0)])
    md, data, figures = written(series(board, ref, {"y": Tolerance(abs=0.1)}), tmp_path)
    assert "not checked" in row(md, "m") and "pass" not in row(md, "m")
    assert data["outputs"]["m"]["reference"]["passed"] is None
    assert figures.verdict.word == "PASS" and "not checked: m" in figures.verdict.reason


def test_a_run_with_nothing_checked_says_so_and_does_not_pass(tmp_path) -> None:  # noqa: ANN001
    md, data, figures = written(series(np.ones(20), np.ones(20), {}), tmp_path)
    assert "Overall: **NOT CHECKED**" in md and "no output has a tolerance" in md
    assert data["pass"] is False and figures.verdict.exit_status == 1
    assert "NOT CHECKED" in console_text(figures)


@pytest.mark.parametrize(
    ("ending", "word", "status"),
    [
        ({"ended": "failed", "error": "board lost after 20 of 100 samples: no reply"}, "FAILED", 2),
        ({"ended": "interrupted", "error": "stopped by Ctrl-C"}, "INTERRUPTED", 130),
        ({"ended": "interrupted", "stop_signal": signal.SIGTERM}, "INTERRUPTED", 143),
        ({"ended": "interrupted", "stop_signal": signal.SIGHUP}, "INTERRUPTED", 129),
        ({"ended": "completed"}, "FAILED", 2),  # 20 of the 100 expected: incomplete
    ],
)
def test_a_run_that_did_not_complete_is_never_pass(tmp_path, ending, word, status) -> None:  # noqa: ANN001
    s = series(np.ones(20), np.ones(20), {"y": Tolerance(abs=0.1)}, expected=100, **ending)
    md, data, figures = written(s, tmp_path)
    assert md.splitlines()[2].startswith(f"Overall: **{word}**") and "PASS" not in md
    assert row(md, "y").endswith("| pass over 20 of 100 samples only |")
    assert "pass over 20 of 100 samples only" in console_text(figures)
    assert data["pass"] is False and data["verdict"]["word"] == word
    assert figures.verdict.exit_status == status == data["exit_status"]


def test_a_board_that_refused_config_leaves_no_output_reading_pass(tmp_path) -> None:  # noqa: ANN001
    error = "after 0 of 100 samples: board refused CONFIG: BAD_PARAM"
    tol = {"y": Tolerance(abs=0.1)}
    s = series(np.empty((0, 1)), [], tol, expected=100, ended="failed", error=error)
    md, data, figures = written(s, tmp_path)
    assert "not checked" in row(md, "y") and "pass" not in row(md, "y")
    assert "pass" not in console_text(figures).split("FAILED")[0]
    assert figures.verdict.word == "FAILED" and "BAD_PARAM" in figures.verdict.reason


def test_bit_exactness_on_the_native_board_is_not_checked(tmp_path) -> None:  # noqa: ANN001
    tol = {"y": Tolerance(abs=0.1, bit_exact=True)}
    s = series(np.ones(20), np.ones(20), tol, native_board=True)
    md, data, figures = written(s, tmp_path)
    assert "bits not checked" in row(md, "y") and "bit-exact" not in row(md, "y")
    assert data["outputs"]["y"]["bit_exact"]["passed"] is None
    assert "bits not checked" in console_text(figures)


def test_bit_exactness_is_checked_where_native_outputs_exist(tmp_path) -> None:  # noqa: ANN001
    tol = {"y": Tolerance(abs=0.1, bit_exact=True)}
    native = np.ones((20, 1))
    native[3] = 1.0 + 2**-20
    figures = compare.evaluate(series(np.ones(20), np.ones(20), tol, native=native))
    assert figures.outputs["y"].bit_exact == compare.BitExactCheck(1, False)
    assert figures.verdict.word == "FAIL" and "y (bits)" in figures.verdict.reason


def test_runs_with_no_output_in_common_share_nothing_to_compare() -> None:
    a = series(np.ones(10), np.ones(10), {}, names=["y"])
    b = series(np.ones(10), np.ones(10), {}, names=["v"])
    d = compare.diff_runs(a, b)
    assert not d["identical"] and d["outputs"] == {} and d["only_in"] == [["y"], ["v"]]


def test_cycles_of_different_boards_are_not_compared_as_a_change() -> None:
    a = series(np.ones(10), np.ones(10), {}, board_name="native")
    b = series(np.ones(10), np.ones(10), {}, board_name="simavr")
    b.cycles[:] = 9393
    d = compare.diff_runs(a, b)
    c = Console(width=300, record=True)
    c.print(report.diff_table(d, "a", "b"))
    text = c.export_text()
    assert "different boards, not compared" in text and "%" not in text
    same = compare.diff_runs(a, series(np.ones(10), np.ones(10), {}, board_name="native"))
    assert same["cycles_comparable"]


def test_truth_metrics_count_from_score_from_s(tmp_path) -> None:  # noqa: ANN001
    """A filter that starts 10 off and converges by t = 1 s: scored from 1 s its RMS is its
    accuracy (0.01), not its start-up; the worst sample is named in the whole run's indices."""
    truth = np.zeros(300)
    board = np.where(np.arange(300) < 100, 10.0, 0.01)
    board[250] = 0.05
    tol = {"y": Tolerance(abs=1.0, truth_rms=0.1)}
    whole = compare.evaluate(series(board, board, tol, truth={"y": truth}))
    assert whole.outputs["y"].truth.rmse > 5 and whole.outputs["y"].truth.passed is False
    s = series(board, board, tol, truth={"y": truth}, score_from_s=1.0)
    md, data, figures = written(s, tmp_path)
    t = figures.outputs["y"].truth
    assert t.rmse == pytest.approx(np.sqrt((199 * 0.01**2 + 0.05**2) / 200))
    assert (t.max_abs, t.worst_k, t.from_s, t.passed) == (0.05, 250, 1.0, True)
    assert figures.passed and "from 1 s" in row(md, "y")
    assert data["outputs"]["y"]["truth"]["from_s"] == 1.0


def test_divergence_fails_a_run_in_tolerance_and_other_flags_are_shown(tmp_path) -> None:  # noqa: ANN001
    n = 50
    ok = {"y": Tolerance(abs=0.1)}
    s = series(np.ones(n), np.ones(n), ok)
    s.status[10:20] = SCHEMA.status["DIVERGED"]
    s.status[30] = SCHEMA.status["CLAMPED"]
    md, data, figures = written(s, tmp_path)
    assert figures.verdict.word == "FAIL" and not data["pass"]
    assert (
        figures.verdict.reason
        == "DIVERGED on 10 samples (first at t = 0.1 s); flags: CLAMPED x1, DIVERGED x10"
    )
    assert "FAIL" in console_text(figures)
    s.status[10:20] = 0
    figures = compare.evaluate(s)
    assert figures.verdict.word == "PASS" and figures.verdict.reason.endswith("flags: CLAMPED x1")


def test_a_drive_built_to_raise_a_flag_fails_when_it_does_not() -> None:
    n = 50
    s = series(np.ones(n), np.ones(n), {"y": Tolerance(abs=0.1)}, expect_flags=("DIVERGED",))
    assert str(compare.evaluate(s).verdict) == "FAIL: expected DIVERGED, never raised"
    s.status[40:] = SCHEMA.status["DIVERGED"]
    assert compare.evaluate(s).verdict.word == "PASS"


def test_a_tolerance_from_a_sample_checks_from_that_sample_and_says_so(tmp_path) -> None:  # noqa: ANN001
    """A start-up counted in samples (a window filling) is skipped by `from_samples`, named in
    the report; one sample fewer and the start-up fails the check."""
    board = np.where(np.arange(40) < 10, 2.0, 1.0)
    for start, word in ((10, "PASS"), (9, "FAIL")):
        s = series(board, np.ones(40), {"y": Tolerance(abs=0.1, from_samples=start)})
        md, _, figures = written(s, tmp_path)
        assert f"from sample {start}" in row(md, "y") and figures.verdict.word == word


def test_a_multi_line_error_stays_inside_report_md_s_bullet_and_verdict(tmp_path) -> None:  # noqa: ANN001
    error = "board lost after 5 of 100 samples: no reply\nsimavr was killed by SIGKILL"
    tol = {"y": Tolerance(abs=0.1)}
    s = series(np.ones(5), np.ones(5), tol, expected=100, ended="failed", error=error)
    figures = compare.evaluate(s)
    md = report.write(s, figures, {"title": "t", "error": error}, tmp_path).read_text()
    lines = md.splitlines()
    assert lines[2] == f"Overall: **FAILED**: {error.replace(chr(10), '; ')}"
    assert "- **error**: board lost after 5 of 100 samples: no reply" in lines
    assert "  simavr was killed by SIGKILL" in lines  # the bullet's own continuation


def test_a_real_time_run_s_late_results_are_in_its_verdict() -> None:
    late = np.zeros(20, dtype=bool)
    late[[3, 7, 11]] = True
    s = series(np.ones(20), np.ones(20), {"y": Tolerance(abs=0.1)}, expected=20)
    figures = compare.evaluate(dataclasses.replace(s, late=late))
    assert str(figures.verdict) == "PASS: 20 of 20 samples checked; 3 late"
    assert str(compare.evaluate(s).verdict) == "PASS: 20 of 20 samples checked"


def test_a_tolerance_that_starts_after_the_last_sample_checked_nothing(tmp_path) -> None:  # noqa: ANN001
    s = series(np.ones(20), np.ones(20), {"y": Tolerance(abs=0.1, from_s=5.0)})
    md, data, figures = written(s, tmp_path)
    assert data["outputs"]["y"]["reference"]["passed"] is None
    assert "not checked (no sample from the tolerance's start on)" in row(md, "y")
    assert figures.verdict.word == "NOT CHECKED" and figures.verdict.exit_status == 1
