"""Faults on the link to the firmware (simavr, QEMU): every one detected, none accepted."""

import random

import pytest

from vehil.boards import open_board
from vehil.errors import LinkError
from vehil.faults_report import measure

pytestmark = pytest.mark.hil

RATE = 1e-2  # per byte, both directions


@pytest.mark.parametrize("board", ["simavr", "qemu"])
@pytest.mark.parametrize("kind", ["drop", "flip", "dup", "insert"])
def test_each_fault_class_is_detected_and_nothing_wrong_is_accepted(board, kind) -> None:  # noqa: ANN001
    r = measure(board, kind, RATE, pings=30 if board == "simavr" else 20)
    assert r["injected"] > 0 and r["detected"] > 0 and r["ok"] > 0
    assert r["wrong"] == 0, "a corrupted reply was accepted"
    assert r["recovered"] >= 0.85 * r["sent"]  # PINGs are sent again; 0.62 get through a try
    assert "SAMPLE" in r["loss"]  # a lost sample ends the stream, named, never skipped


def _answers_again(link, attempts: int = 40) -> bool:  # noqa: ANN001
    """PINGs until one comes back right: late replies and the board's own error
    reports (oversize, overrun) from the storm are read past on the way."""
    link.timeout_s = 0.5
    for _ in range(attempts):
        try:
            if link.request("PING", payload=b"still here").fields()["payload"] == b"still here":
                return True
        except LinkError:
            continue
    return False


@pytest.mark.parametrize("board", ["simavr", "qemu"])
def test_a_storm_of_garbage_and_malformed_frames_leaves_the_board_answering(board) -> None:  # noqa: ANN001
    with open_board(board, timeout_s=1.0) as link:
        before = link.stats()
        rng = random.Random(11)
        link.port.write(bytes(rng.randrange(256) for _ in range(1000)))
        link.port.write(b"\x01" * 400 + b"\x00")  # oversize: longer than any frame
        link.port.write(b"\x05\x01\x02\x03\x00")  # COBS-valid, CRC wrong
        assert _answers_again(link)
        after = link.stats()
        assert (
            after["crc_errors"] + after["cobs_errors"]
            > before["crc_errors"] + before["cobs_errors"]
        )
        assert after["oversize"] > before["oversize"]
