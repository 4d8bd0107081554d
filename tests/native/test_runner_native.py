"""The runner end to end on the native board: run, record, report, replay, compare."""

import dataclasses

import numpy as np

from vehil import compare, record, report, runner, scenario


def test_a_float_run_matches_the_reference_and_is_recorded(run_scenario, tmp_path) -> None:  # noqa: ANN001
    result = run_scenario("sine", board="native", duration=2.0)
    result.assert_passed()
    rec = record.read(result.recording)
    assert len(rec) == 1000 and rec.end["ended"] == "completed"
    assert rec.header["estimator"]["name"] == "passthrough"
    assert rec.header["board"]["info"]["f_cpu"] == 1_000_000_000
    # The board's float32 result is the input rounded once: never further than half an ulp.
    ref = rec.data["ref.y"]
    assert np.all(np.abs(rec.data["board.y"] - ref) <= np.abs(ref) * 2.0**-24)
    md = report.write(
        compare.series_from_recording(rec), result.figures, {"title": "t"}, tmp_path / "report"
    )
    assert "PASS" in md.read_text()
    assert (tmp_path / "report" / "y.png").stat().st_size > 10_000


def test_fixed_point_outputs_are_the_inputs_rounded_to_the_q_format(run_scenario) -> None:  # noqa: ANN001
    result = run_scenario("sine-fixed", board="native", duration=1.0)
    result.assert_passed()
    run = result.run
    lsb = 2.0**-24
    np.testing.assert_array_equal(
        run.board_out[:, 0], np.round(run.prepared.inputs[:, 0] / lsb) * lsb
    )


def test_a_replayed_recording_gives_identical_results(run_scenario, tmp_path) -> None:  # noqa: ANN001
    first = run_scenario("sine", board="native", duration=1.0)
    sc = scenario.load("sine")
    data = dict(sc.raw)
    data.pop("plant")
    data["scenario"] = {k: v for k, v in data["scenario"].items() if k != "duration"}
    data["log"] = {"path": str(first.recording), "format": "vehil"}
    replay = scenario.parse(data, "replay", sc.path)
    second = runner.run(replay, "native", recording=tmp_path / "replay.arrow")
    assert second.ended == "completed" and second.done == 500
    a = compare.series_from_recording(record.read(first.recording))
    b = compare.series_from_recording(record.read(second.recording))
    assert compare.diff_runs(a, b)["identical"]
    changed = dataclasses.replace(b, board=b.board + 1e-6)
    d = compare.diff_runs(a, changed)
    assert not d["identical"] and d["outputs"]["y"]["first_difference_k"] == 0


def test_a_tolerance_too_tight_fails_and_names_the_worst_sample(run_scenario) -> None:  # noqa: ANN001
    sc = scenario.load("sine")
    tight = dataclasses.replace(sc, tolerances={"y": scenario.Tolerance(abs=0.0, rel=1e-9)})
    result = run_scenario(tight, board="native", duration=1.0)
    assert not result.passed
    ref = result.figures.outputs["y"].reference
    assert ref.outside_tolerance > 0 and ref.worst_k is not None


def test_a_loop_that_gets_wrong_feedback_drifts_off(run_scenario) -> None:  # noqa: ANN001
    from vehil import plants

    good = run_scenario("sine-loop", board="native", duration=1.0)
    good.assert_passed()
    loop = plants.get("noisy_sine").start_loop({"tau": 0.05}, 0.002, 2)
    for _ in range(500):  # the same loop fed a stuck output instead of the board's echo
        loop.measure()
        loop.apply({"y": 0.0})
    _, _, truth = loop.measure()
    assert abs(truth["y"]) > 1.0  # it ran away: feedback is what kept the run on track


def test_a_closed_loop_survives_a_board_reset_with_the_same_outputs(built) -> None:  # noqa: ANN001
    """The loop's plant is not rerun: the rebooted board catches up on the samples it had
    answered, each answer checked, and the loop goes on from where it was."""
    from rich.console import Console

    from vehil.boards import BoardOptions, make_board

    sc = dataclasses.replace(scenario.load("s5-iso-active-eso"), duration=5.0)
    broken = runner.run(
        sc,
        make_board("native", BoardOptions(faults="reboot_after=300")),
        console=Console(quiet=True),
    )
    clean = runner.run(sc, "native", console=Console(quiet=True))
    assert broken.ended == "completed" and [r.at_sample for r in broken.resumes] == [299]
    assert (broken.board_out == clean.board_out).all()


def test_a_recording_keeps_the_scenarios_score_from_s(tmp_path) -> None:  # noqa: ANN001
    """UIIEKF starts from its initial guess: scored from 1 s its truth RMS is lower, and the
    recording read back scores from the same time."""
    sc = scenario.load("uiiekf3-abs-dry")
    later = dataclasses.replace(sc, score_from_s=1.0)
    run = runner.run(later, "native", recording=tmp_path / "run.arrow")
    fresh = run.figures.outputs["v"].truth
    recorded = compare.series_from_recording(record.read(run.recording))
    read = compare.evaluate(recorded)
    whole = compare.evaluate(dataclasses.replace(recorded, score_from_s=0.0)).outputs["v"].truth
    assert fresh == read.outputs["v"].truth and fresh.from_s == 1.0
    assert fresh.rmse < whole.rmse and fresh.worst_k >= 100


def test_ctrl_c_while_the_bits_are_checked_leaves_the_run_judged_interrupted(
    built,  # noqa: ANN001
    tmp_path,  # noqa: ANN001
    monkeypatch,  # noqa: ANN001
) -> None:
    from vehil.boards.native import NativeBoard

    class ABoard(NativeBoard):  # a board whose bits are checked against the native build's
        name = "a-board"

    def ctrl_c(*_: object) -> dict[str, int]:
        raise KeyboardInterrupt

    monkeypatch.setattr(runner, "native_mismatches", ctrl_c)
    sc = dataclasses.replace(scenario.load("braking/manf-hard-stop-fixed"), duration=0.05)
    run = runner.run(sc, ABoard(), recording=tmp_path / "run.arrow")
    assert run.done == 50 and len(record.read(tmp_path / "run.arrow")) == 50
    verdict = run.figures.verdict
    assert verdict.word == "INTERRUPTED" and verdict.exit_status == 130
    assert "while the board's bits were checked" in verdict.reason
    assert "bits not checked" in verdict.reason
    assert run.figures.outputs["v"].bit_exact.passed is None  # n/a, not a pass


def test_a_board_that_reboots_after_its_last_sample_fails_the_run_and_says_so(built) -> None:  # noqa: ANN001
    """Every sample answered, then the board reset before the stack high-water was read
    (a REBOOT slipped in right after the last SAMPLE): not a PASS, and the error says all
    the samples were in."""
    from rich.console import Console

    from vehil.boards import BoardOptions, make_board
    from vehil.link import config_requests
    from vehil.protocol.schema import SCHEMA

    sc = dataclasses.replace(scenario.load("sine"), duration=0.2)
    spec = sc.estimator
    params = spec.encode_params(sc.params, sc.mode)
    writes = len(config_requests(spec.c_id, SCHEMA.mode[sc.mode], params)) + sc.samples
    board = make_board("native", BoardOptions(faults=f"reboot_after={writes}"))
    run = runner.run(sc, board, console=Console(quiet=True))
    assert run.done == sc.samples and not run.resumes
    assert run.ended == "failed" and run.figures.verdict.word == "FAILED"
    assert run.error.startswith(f"board lost after its last sample (all {sc.samples} answered)")
    assert "rebooted" in run.error
