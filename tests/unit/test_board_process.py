"""A board program run by BoardProcess: it never outlives the host, and a missing one is
named."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time

import pytest

from vehil.boards.process import BoardProcess, _dies_with_parent
from vehil.errors import BoardStartError

# A host that starts a board program (here `sleep`) and a thread beside it, as vehil's
# frame maker is, prints the program's pid, and waits to be killed.
HOST = """
import threading, time
from vehil.boards.process import BoardProcess, _dies_with_parent
threading.Thread(target=time.sleep, args=(60,), daemon=True).start()
board = BoardProcess(["sleep", "60"], "sleep")
print(board.proc.pid, flush=True)
time.sleep(60)
"""


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(") ")[1][0] != "Z"
    except FileNotFoundError:
        return False


def _comm(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/comm") as f:
            return f.read().strip()
    except FileNotFoundError:
        return ""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="parent-death signal is Linux's")
def test_a_host_killed_outright_takes_its_board_program_with_it() -> None:
    host = subprocess.Popen([sys.executable, "-c", HOST], stdout=subprocess.PIPE, text=True)
    assert host.stdout is not None
    pid = int(host.stdout.readline())
    # setpriv sets the signal, then execs the program: wait for the exec, as the host does
    # (it waits for the board's ready line), so the signal is set when the host dies
    deadline = time.monotonic() + 10
    while _comm(pid) != "sleep" and time.monotonic() < deadline:
        time.sleep(0.01)
    assert _alive(pid)
    host.send_signal(signal.SIGKILL)
    host.wait(timeout=10)
    deadline = time.monotonic() + 10
    while _alive(pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    alive = _alive(pid)
    if alive:
        os.kill(pid, signal.SIGKILL)
    assert not alive, "the board program outlived its host"


# A host with gRPC running (labgrid's client), starting board programs: gRPC's fork
# handlers, which restart its poller in a forked child, once aborted the child before it
# could exec. Started without Python code in the child, no fork handler runs at all.
GRPC_HOST = """
import grpc
from concurrent import futures
from vehil.boards.process import BoardProcess, _dies_with_parent
server = grpc.server(futures.ThreadPoolExecutor(max_workers=2))
port = server.add_insecure_port("127.0.0.1:0")
server.start()
grpc.channel_ready_future(grpc.insecure_channel(f"127.0.0.1:{port}")).result(timeout=10)
for _ in range(10):
    board = BoardProcess(["true"], "true")
    assert board.proc.wait(timeout=10) == 0, board.stderr_tail()
"""


def test_a_board_program_started_beside_grpc_runs_no_fork_handler() -> None:
    pytest.importorskip("grpc")
    done = subprocess.run(
        [sys.executable, "-c", GRPC_HOST], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert "fork" not in done.stderr, done.stderr


def test_a_missing_board_program_is_named() -> None:
    with pytest.raises(
        BoardStartError, match="cannot start simavr: /no/such/bridge: no such program"
    ):
        BoardProcess(["/no/such/bridge"], "simavr")


@pytest.mark.skipif(shutil.which("setpriv") is None, reason="setpriv sets the signal")
def test_a_board_program_whose_host_died_before_the_signal_was_set_never_starts(tmp_path) -> None:  # noqa: ANN001
    """The guard setpriv runs checks that its parent is still the host that spawned it."""
    started = tmp_path / "started"
    argv = _dies_with_parent(["touch", str(started)])
    host = argv.index(str(os.getpid()))
    assert subprocess.run(argv).returncode == 0 and started.exists()
    started.unlink()
    argv[host] = "1"  # as seen by a child whose host has gone: another parent
    assert subprocess.run(argv).returncode != 0 and not started.exists()


def test_a_board_program_that_ends_says_how() -> None:
    board = BoardProcess(["sh", "-c", "echo broke >&2; exit 3"], "bridge")
    with pytest.raises(BoardStartError, match="bridge exited with status 3 before it was ready"):
        board.read_line(10)
    killed = BoardProcess(["sleep", "60"], "bridge")
    assert killed.state() == "is still running"
    killed.proc.send_signal(signal.SIGKILL)
    killed.proc.wait(timeout=10)
    assert killed.state() == "was killed by SIGKILL"
    board.stop()
    killed.stop()
