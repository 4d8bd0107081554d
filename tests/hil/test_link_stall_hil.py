"""A board that stalls while SAMPLEs stream: the host's go-back-N resends run on, no
RESULT of another sample is ever taken for the one asked, and the resends never
overrun the board's RX buffer when it wakes.

With v2's 8-bit seq, a few seconds of stall (a starved simulator on a loaded machine)
made the resends wrap the seq space while the old copies waited in the board's input;
an old RESULT with a reused seq and the same type was then accepted as the answer.
Then the host sent every unanswered request again on each timeout, so the copies the
stalled board had not read piled up behind it: several RX buffers' worth, which it
could not read as fast as they came when it woke (an OVERRUN, the run lost).
"""

import os
import signal
import struct
import threading

import pytest

from vehil.boards import BoardOptions, make_board

pytestmark = pytest.mark.hil

STALL_S = 4.5  # forty timeouts of 0.1 s
SAMPLES = 3000


def test_a_stalled_board_is_never_sent_more_than_its_rx_buffer_holds(built) -> None:  # noqa: ANN001
    board = make_board("simavr", BoardOptions(timeout_s=0.1))
    with board.session() as link:
        assert board.process is not None and link.info is not None
        pid = board.process.proc.pid
        link.configure("passthrough", "F32")
        overruns_before = link.stats()["overruns"]

        # The stall starts mid-stream, counted in samples and sent from this thread: on a
        # quiet host all 3,000 can pass in a quarter of a second, so a stall timed in
        # seconds, or started by a thread a loaded host is slow to run, could come too late.
        stall_at = SAMPLES // 10
        wake = threading.Timer(STALL_S, os.kill, (pid, signal.SIGCONT))
        wake.daemon = True
        wrong = taken = most_in_flight = 0
        inputs = (struct.pack("<4f", k, k, k, k) for k in range(SAMPLES))
        # 40 retries: with the backoff, ~10 s of silence before the board counts as lost.
        samples = (("SAMPLE", {"inputs": x}) for x in inputs)
        for k, reply in enumerate(link.pipeline(samples, retries=40)):
            if k == stall_at:
                os.kill(pid, signal.SIGSTOP)
                wake.start()
            wrong += reply.fields()["outputs"] != struct.pack("<4f", k, k, k, k)
            taken += 1
            most_in_flight = max(most_in_flight, link.in_flight)
        stats = link.stats()
    assert link.retried >= 10  # the stall was seen: timeouts, resends and probes
    assert taken == SAMPLES and wrong == 0
    assert stats["overruns"] == overruns_before
    assert most_in_flight <= link.info.rx_buffer
