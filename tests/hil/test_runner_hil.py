"""Scenarios streamed through the firmware on simavr and QEMU: the product's regression."""

import contextlib
import threading

import numpy as np
import pytest
from live_run import wait_for_samples

from vehil import record, runner, scenario
from vehil.boards import BoardOptions
from vehil.boards.simavr import SimavrBoard

pytestmark = pytest.mark.hil


@pytest.mark.parametrize(("board", "duration"), [("simavr", 10.0), ("qemu", 2.0)])
def test_the_synthetic_scenario_passes_on_each_virtual_board(run_scenario, board, duration) -> None:  # noqa: ANN001
    result = run_scenario("sine", board=board, duration=duration)
    result.assert_passed()
    assert result.run.done == int(duration / 0.002)
    # The board's stack high-water, read after the run, travels into the figures.
    assert 40 < result.figures.stack_bytes < result.run.info["free_ram"]
    assert record.read(result.recording).end["stack_bytes"] == result.figures.stack_bytes


def test_fixed_point_on_the_chip_is_bit_exact_with_the_native_build(run_scenario) -> None:  # noqa: ANN001
    result = run_scenario("sine-fixed", board="simavr", duration=4.0)
    result.assert_passed()
    assert result.figures.outputs["y"].bit_exact.mismatches == 0
    assert 0 < result.figures.cycles["median"] < 1000


def test_a_closed_loop_through_the_chip_follows_the_native_build_exactly(run_scenario) -> None:  # noqa: ANN001
    from vehil import compare

    chip = run_scenario("sine-loop", board="simavr", duration=2.0)
    chip.assert_passed()
    host = run_scenario("sine-loop", board="native", duration=2.0)
    a = compare.series_from_recording(record.read(host.recording))
    b = compare.series_from_recording(record.read(chip.recording))
    assert compare.diff_runs(a, b)["identical"]
    # The loop really runs through the board: its truth tracks the set point.
    assert chip.figures.outputs["y"].truth.rmse < 0.03


def test_real_time_pacing_holds_the_sample_rate(run_scenario) -> None:  # noqa: ANN001
    result = run_scenario("sine", board="simavr", duration=1.0, realtime=True)
    result.assert_passed()
    assert result.run.wall_s >= 0.95  # 500 samples at 2 ms cannot finish sooner
    assert len(result.run.late) == 500


def test_a_board_that_dies_mid_run_fails_the_run_and_keeps_the_recording(tmp_path) -> None:  # noqa: ANN001
    board = SimavrBoard(BoardOptions(timeout_s=0.5))
    sc = scenario.load("sine")

    def kill_when_running() -> None:
        # Once samples are recorded, however long a loaded host took to get there: a fixed
        # 1.5 s from the start killed the board before its first sample under load.
        while True:
            threading.Event().wait(0.05)
            with contextlib.suppress(FileNotFoundError, record.RecordingError):
                if len(record.read(tmp_path / "run.arrow")) > 0:
                    break
        assert board.process is not None
        board.process.proc.kill()

    threading.Thread(target=kill_when_running, daemon=True).start()
    run = runner.run(sc, board, realtime=True, recording=tmp_path / "run.arrow")
    assert run.ended == "failed"
    assert "connection to the board broke" in run.error or "no reply" in run.error
    rec = record.read(tmp_path / "run.arrow")
    assert rec.end["ended"] == "failed" and rec.end["error"] == run.error
    assert 0 < len(rec) == run.done < sc.samples
    np.testing.assert_array_equal(rec.data["k"], np.arange(len(rec)))


def test_the_stack_read_after_a_run_goes_through_whatever_faults_the_run_had() -> None:
    """The stack high-water read once every sample is in is a diagnostic, not the run's:
    --faults break the run's exchanges, not it (drop=1e-2 lost it 4 tries in 10, and a
    run whose samples had all passed was failed, now and then, as a lost board)."""
    from vehil.boards import open_board
    from vehil.errors import BoardTimeout

    with open_board("simavr", BoardOptions(timeout_s=0.2, faults="drop=1,seed=1")) as link:
        with pytest.raises(BoardTimeout):  # every byte lost: the faults are on
            link.request("GET_STATS", retries=0)
        used = runner.stack_used(link)
        assert used is not None and 40 < used < link.info.fields["free_ram"]


def _ignore_sigint() -> None:
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def test_ctrl_c_stops_a_run_cleanly_and_keeps_what_was_recorded(tmp_path, built) -> None:  # noqa: ANN001
    """Even a run started with SIGINT ignored, as a shell script's `vehil run ... &` starts
    it (and as pytest itself may be started): vehil sets its own handler."""
    import signal
    import subprocess
    import sys

    out = tmp_path / "run"
    proc = subprocess.Popen(
        [sys.executable, "-m", "vehil", "run", "sine", "--realtime", "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        preexec_fn=_ignore_sigint,
    )
    wait_for_samples(proc, out)
    proc.send_signal(signal.SIGINT)
    output, _ = proc.communicate(timeout=60)
    assert proc.returncode == 130, output
    assert "interrupted" in output
    rec = record.read(out / "run.arrow")
    assert rec.end["ended"] == "interrupted" and 0 < len(rec) < 10_000
    assert (out / "report.md").exists()


# Every shipped scenario with a tolerance runs on the chip, found, not listed: a new one is
# covered as it lands. Each runs its first DEFAULT_SAMPLES (configured, stepping, matching
# its float64 reference from the start) on simavr, or on simavr-ev where its estimator is
# not in the default image; one built to raise a flag (expect_flags) runs whole, to its
# event. These run longer, the drive's point coming later (or a truth bound scored over
# the whole drive):
DEFAULT_SAMPLES = 50
LONGER = {
    "mixed": 30.0,
    "mixed-fixed": 30.0,
    "manf-hard-stop": 4.0,
    "manf-hard-stop-fixed": 4.0,
    "manf-abs-snow": 6.0,
    "manf-wet-fast-fixed": 8.0,  # unlike the shipped drives
    "manf-heavy-hifi-fixed": 1.0,  # 2.6 t on the hi-fi plant: the gains part at 0.3 s
    "anf-abs-snow-fixed": 3.0,  # bit-exact with the native build
    "uiiekf3-abs-dry": 1.5,
    "mismatch-iso-c60-kfui": 3.0,  # a quarter car the KF-UI does not know
    "mismatch-bumps30-eso-tuned-fixed": 1.0,
    "s1-dlc80-ekf3-hifi": 1.0,  # an EV the EKF does not know
    "s1-dlc80-ekf3-suv": 1.0,  # an EV the EKF is given: its tire terms' general forms
    "paper-dither": 15.0,
    "rls-flat-steps": 20.0,
    "rls-flat-steps-fixed": 20.0,  # bit-exact with the native build
    "rls-heavy-fixed": 60.0,  # its truth bound is over the whole drive, from 1000 kg
    "rls-heavy-rolling-fixed": 20.0,  # unlike the shipped drives
    "rls-heavy-200hz-fixed": 17.0,  # 2.9 t at 200 Hz braking past the old 32 kN at 16 s
    "rls-no-excitation-fixed": 10.0,  # built to raise ILL_CONDITIONED: from its first second
    "rls-walk-noisy-fixed": 5.0,  # θ3's random walk at 200 Hz: bit-exact with the native build
    "paper-dither-fixed": 15.0,  # bit-exact with the native build
    "mass-step-fixed": 45.0,  # past the +300 kg at 40 s
    "van-rolling-fixed": 10.0,  # unlike the shipped drives
    "light-50hz-fixed": 3.0,  # a 1200 kg car at 50 Hz: past the start-up's 25 samples
    "heavy-200hz-fixed": 4.0,  # a 3440 kg vehicle at 200 Hz: C_dA_f checked from 3 s
    "well-excited-adaptive-fixed": 10.0,  # μ adapting
    "s1-sine-eso-fixed": 5.0,
    "unlike-bumps-200hz-fixed": 2.0,  # unlike the shipped drives: bit-exact with the native build
    "s5-iso-active-eso": 5.0,  # closed loop: the board's force drives the car
    "s6-iso-active-kfui": 3.0,
    "s1-dlc80-ekf3-linear": 3.0,  # seed 001's variant that keeps 10 ms
    "s3-tcs-low-mu-ekf": 1.0,  # its truth bound needs the first second
}
# and these on QEMU too (the -ev image where the estimator needs it)
ON_QEMU = {
    "hard-braking": 6.0,
    "rls-truck-fixed": 5.0,
    "rls-no-excitation-fixed": 2.0,  # the health test's exponent compares on a second core
    "paper-dither-fixed": 2.0,
    "mass-step": 3.0,
    "s5-iso-active-eso-fixed": 1.0,
    "s1-dlc80-ekf3-linear": 1.0,
    "s1-dlc80-ekf3-suv": 0.5,
    "s2-sine80-ekf": 0.3,
    "s6-sine100-low-mu-ukf": 1.0,
}


def _discovered() -> list[tuple[str, str, float]]:
    from vehil.build import registry
    from vehil.build.platformio import default_estimators

    in_default = set(registry.select(default_estimators()))
    runs = []
    for path in scenario.shipped():
        sc = scenario.load(path)
        if not sc.tolerances:  # a figure's drive (vehil reproduce), with nothing to check
            continue
        ev = "" if sc.estimator.name in in_default else "-ev"
        whole = sc.duration if sc.expect_flags else DEFAULT_SAMPLES * sc.sample_time
        runs.append((sc.name, f"simavr{ev}", min(sc.duration, LONGER.get(sc.name, whole))))
        if sc.name in ON_QEMU:
            runs.append((sc.name, f"qemu{ev}", ON_QEMU[sc.name]))
    return runs


def test_the_discovery_finds_every_scenario_the_tables_name() -> None:
    names = {name for name, _, _ in _discovered()}
    assert set(LONGER) | set(ON_QEMU) <= names  # a renamed scenario is not silently dropped
    assert len(names) > 50


@pytest.mark.parametrize(("name", "board", "duration"), _discovered())
def test_estimators_on_the_chip_match_their_references(run_scenario, name, board, duration) -> None:  # noqa: ANN001, E501
    result = run_scenario(name, board=board, duration=duration)
    result.assert_passed()
