"""How a run ends decides its verdict: a board lost mid-run or a host stopped by a signal
leaves a closed recording and a report that says so, never PASS, and the board stopped."""

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from live_run import wait_for_samples

from vehil import record

pytestmark = pytest.mark.hil


def _start_run(out: Path) -> subprocess.Popen:
    """`vehil run sine` on simavr at real time (20 s), once its first samples are recorded."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "vehil", "run", "sine", "--board", "simavr", "--realtime",
         "--out", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    wait_for_samples(proc, out)
    return proc


def _children(pid: int) -> list[int]:
    text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    return [int(c) for c in text.split()]


def _gone(pid: int, within_s: float = 5.0) -> bool:
    deadline = time.monotonic() + within_s
    while time.monotonic() < deadline:
        try:
            if Path(f"/proc/{pid}/stat").read_text().split(")")[1].split()[0] == "Z":
                return True  # a zombie has stopped; its parent is gone
        except FileNotFoundError:
            return True
        time.sleep(0.05)
    return False


def _report(out: Path) -> tuple[str, dict]:
    return (out / "report.md").read_text(), json.loads((out / "figures.json").read_text())


def test_a_board_lost_mid_run_is_failed_with_the_samples_it_got(built, tmp_path) -> None:  # noqa: ANN001
    proc = _start_run(tmp_path)
    for child in _children(proc.pid):
        subprocess.run(["kill", "-KILL", str(child)], check=False)
    said, _ = proc.communicate(timeout=60)
    assert proc.returncode == 2, said
    md, figures = _report(tmp_path)
    assert "Overall: **FAILED**" in md and "board lost after" in md and "PASS" not in md
    assert figures["pass"] is False and figures["verdict"]["word"] == "FAILED"
    assert 0 < figures["samples"] < figures["expected"] == 10_000
    assert "FAILED: board lost after" in said
    assert record.read(tmp_path / "run.arrow").end["ended"] == "failed"


@pytest.mark.parametrize(
    ("sig", "status", "by"),
    [
        (signal.SIGTERM, 143, "SIGTERM"),
        (signal.SIGHUP, 129, "SIGHUP"),
        (signal.SIGINT, 130, "Ctrl-C"),
    ],
)
def test_a_signal_ends_a_run_with_its_recording_closed_and_report_written(
    built,
    tmp_path,
    sig,
    status,
    by,  # noqa: ANN001
) -> None:
    proc = _start_run(tmp_path)
    board = _children(proc.pid)
    assert board, "no board process"
    proc.send_signal(sig)
    said, _ = proc.communicate(timeout=60)
    assert proc.returncode == status, said
    rec = record.read(tmp_path / "run.arrow")
    assert rec.truncated is None and rec.end["ended"] == "interrupted"
    assert f"stopped by {by}" in rec.end["error"] and rec.end["signal"] == sig
    md, figures = _report(tmp_path)
    assert "Overall: **INTERRUPTED**" in md and figures["pass"] is False
    assert figures["exit_status"] == status and 0 < figures["samples"] < 10_000
    assert "INTERRUPTED" in said
    assert all(_gone(pid) for pid in board), "the board process outlived the run"
