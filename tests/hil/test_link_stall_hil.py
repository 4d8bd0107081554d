"""A board that stalls while SAMPLEs stream: the host's go-back-N resends run on, and
no RESULT of another sample is ever taken for the one asked.

With v2's 8-bit seq, a few seconds of stall (a starved simulator on a loaded machine)
made the resends wrap the seq space while the old copies waited in the board's input;
an old RESULT with a reused seq and the same type was then accepted as the answer.
"""

import os
import signal
import struct
import threading
import time

import pytest

from vehil.boards import BoardOptions, make_board
from vehil.errors import LinkError

pytestmark = pytest.mark.hil

STALL_S = 4.5  # long enough for more than 255 resends at a 0.1 s timeout


def test_no_old_result_is_taken_after_a_stall_and_many_resends(built) -> None:  # noqa: ANN001
    board = make_board("simavr", BoardOptions(timeout_s=0.1))
    with board.session() as link:
        assert board.process is not None
        pid = board.process.proc.pid
        link.configure("passthrough", "F32")

        def stall() -> None:
            time.sleep(0.3)
            os.kill(pid, signal.SIGSTOP)
            time.sleep(STALL_S)
            os.kill(pid, signal.SIGCONT)

        threading.Thread(target=stall, daemon=True).start()
        first = link._seq
        wrong = taken = 0
        try:
            inputs = (struct.pack("<4f", k, k, k, k) for k in range(3000))
            for k, reply in enumerate(
                link.pipeline((("SAMPLE", {"inputs": x}) for x in inputs), retries=20)
            ):
                wrong += reply.fields()["outputs"] != struct.pack("<4f", k, k, k, k)
                taken += 1
        except LinkError:
            pass  # the backlog may overrun the board's RX ring when it wakes: a loss, reported
        sent = link._seq - first
    assert link.retried >= 16 and sent > 255  # the resends went past v2's seq space
    assert taken > 0 and wrong == 0
