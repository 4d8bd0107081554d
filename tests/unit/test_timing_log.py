"""The bridge's timing log read against a real-time run: where a late stretch's time went."""

import numpy as np

from vehil.timing_log import TimingLog

MS = 1_000_000  # ns


def test_a_late_stretch_is_put_down_to_the_board_falling_behind_while_a_cpu_was_stolen(
    tmp_path,  # noqa: ANN001
) -> None:
    # Three 10 ms samples. Sample 1's request read in two parts; sample 1's reply went out
    # 30 ms behind the chip's time, while CPU 1 was given away for 30 ms.
    lines = [
        "in 99000000 99100000 0 99100000 9",  # a configuration request, not a SAMPLE
        "out 99500000 99600000 0 99500000 9",
        f"in {100 * MS} {100 * MS + 10_000} 0 {100 * MS} 24",
        f"out {106 * MS} {106 * MS + 20_000} 0 {106 * MS} 31",
        f"in {110 * MS} {110 * MS + 10_000} 0 {110 * MS} 10",
        f"in {110 * MS + 5000} {110 * MS + 15_000} 0 {110 * MS} 14",
        f"steal {140 * MS} 0 30",
        f"out {146 * MS} {146 * MS + 20_000} 0 {116 * MS} 31",
        f"in {146 * MS + 100_000} {146 * MS + 110_000} 0 {146 * MS} 24",
        f"out {152 * MS} {152 * MS + 20_000} 0 {152 * MS} 31",
        "behind 1 2 3",
    ]
    path = tmp_path / "timing.log"
    path.write_text("\n".join(lines) + "\n")
    log = TimingLog.read(path)
    late = np.array([False, True, True])
    rtt = np.array([6.05, 36.05, 6.0]) * 1e-3
    (stretch,) = log.late_stretches(24, late, rtt, 0.01)
    assert (stretch.first, stretch.samples) == (1, 2)
    assert abs(stretch.past_due_ms - 36.05) < 1e-6
    assert abs(stretch.sent_late_ms) < 1e-6
    assert abs(stretch.board_behind_ms - 30) < 1e-6
    assert stretch.steal_ms == (0, 30)
    assert "30.0 ms behind the wall clock" in stretch.describe()


def test_a_log_short_of_one_request_a_sample_is_not_matched(tmp_path) -> None:  # noqa: ANN001
    path = tmp_path / "timing.log"
    path.write_text(f"in {MS} {MS} 0 {MS} 24\nout {2 * MS} {2 * MS} 0 {2 * MS} 31\n")
    log = TimingLog.read(path)
    assert log.late_stretches(24, np.array([True, True]), np.array([1e-3, 1e-3]), 0.01) is None
