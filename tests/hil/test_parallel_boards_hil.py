"""Boards side by side: each pytest-xdist worker gets its own board, and boards running at
the same time never see each other's bytes."""

import json
import os
import subprocess
import sys
import threading
import time

import pytest

from vehil.boards import BoardOptions, open_board

pytestmark = pytest.mark.hil

PINGS = 1_500


def _tagged_pings(link, tag: bytes, halfway: threading.Barrier) -> dict:  # noqa: ANN001
    """PINGs whose payloads carry `tag`, every echo checked; frames the board received.
    Half of them, then `halfway` (every board has sent half of its own), then the rest:
    the boards' streams overlap however a loaded host schedules them."""
    before = link.stats()["rx_frames"]
    start = time.monotonic()
    payloads = [tag + i.to_bytes(4, "little") for i in range(PINGS)]
    echoes = []
    for part in (payloads[: PINGS // 2], payloads[PINGS // 2 :]):
        replies = link.pipeline((("PING", {"payload": p}) for p in part), window=8)
        echoes += [r.fields()["payload"] for r in replies]
        if part[0] == payloads[0]:
            halfway.wait(timeout=300)
    assert echoes == payloads
    after = link.stats()["rx_frames"]
    return {"received": after - before, "start": start, "end": time.monotonic()}


def test_two_boards_at_once_each_echo_only_their_own_frames(built) -> None:  # noqa: ANN001
    results: dict[str, dict] = {}
    errors: list[BaseException] = []
    # Board A could finish its PINGs before B's simavr had booted on a loaded host.
    halfway = threading.Barrier(2)

    def drive(tag: str) -> None:
        try:
            with open_board("simavr", BoardOptions(timeout_s=5.0)) as link:
                pings = _tagged_pings(link, tag.encode(), halfway)
                results[tag] = {"port": link.port.port, **pings}
        except BaseException as exc:  # reported in the main thread
            halfway.abort()  # the other board does not wait for this one
            errors.append(exc)

    threads = [threading.Thread(target=drive, args=(tag,)) for tag in ("board-A", "board-B")]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    a, b = results["board-A"], results["board-B"]
    assert a["port"] != b["port"]
    assert a["start"] < b["end"] and b["start"] < a["end"], "the two runs did not overlap"
    # Each board's own count of frames received: its PINGs and the STATS that read it, no more.
    assert a["received"] == b["received"] == PINGS + 1


WORKER_TEST = """
import json, os, time

def test_my_board_is_my_own(board, worker_id, tmp_path):
    tag = worker_id.encode()
    start = time.monotonic()
    payloads = [tag + i.to_bytes(4, "little") for i in range(1000)]
    replies = board.pipeline((("PING", {"payload": p}) for p in payloads), window=8)
    assert [r.fields()["payload"] for r in replies] == payloads
    out = os.environ["VEHIL_ISOLATION_OUT"]
    with open(os.path.join(out, worker_id + ".json"), "w") as f:
        json.dump({"port": board.port.port, "tmp": str(tmp_path), "runs": os.environ["VEHIL_RUNS"],
                   "start": start, "end": time.monotonic()}, f)
"""

CONFTEST = """
import os, pytest

@pytest.fixture(scope="session", autouse=True)
def _runs(tmp_path_factory):
    os.environ["VEHIL_RUNS"] = str(tmp_path_factory.mktemp("runs"))
"""


def test_each_xdist_worker_gets_its_own_board_and_folders(built, tmp_path) -> None:  # noqa: ANN001
    """Two workers run the same test at once (--dist each) through the vehil plugin's
    `board` fixture: two boards, two ports, two temporary folders, every echo their own."""
    suite = tmp_path / "suite"
    suite.mkdir()
    (suite / "test_worker.py").write_text(WORKER_TEST)
    (suite / "conftest.py").write_text(CONFTEST)
    out = tmp_path / "out"
    out.mkdir()
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-n",
            "2",
            "--dist",
            "each",
            "-p",
            "no:cacheprovider",
            str(suite),
        ],
        cwd=suite,
        env={**os.environ, "VEHIL_ISOLATION_OUT": str(out)},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    seen = {p.stem: json.loads(p.read_text()) for p in out.glob("*.json")}
    assert sorted(seen) == ["gw0", "gw1"]
    w0, w1 = seen["gw0"], seen["gw1"]
    for key in ("port", "tmp", "runs"):
        assert w0[key] != w1[key], key
