"""The simavr bridge's timing log (`--timing`, sim/README.md "Timing log") read against a
real-time stop-and-wait run: for each stretch of late samples, where its first sample's
time went. The host sent it late (its loop held up), the board answered late (simulated
time behind the wall clock), or the reply waited for the host to read it; and how much CPU
time the hypervisor gave to others meanwhile (steal), which stops every thread on the CPU
it takes, the board's and the host's alike."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

# Steal is read every 10 ms and logged once the bridge's thread runs again: look that far
# past a reply for the steal that held it up.
_STEAL_LAG_S = 0.03


@dataclass(frozen=True)
class LateStretch:
    first: int  # the first late sample
    samples: int  # late samples in a row from it
    past_due_ms: float  # how long after its due time its reply arrived
    sent_late_ms: float  # the host's request, after its due time
    board_behind_ms: float  # simulated time behind the wall clock when the reply went out
    reply_waited_ms: float  # from the reply written to the host to the host having it
    steal_ms: tuple[int, ...]  # per CPU, from a sample time before its due to its reply

    def describe(self) -> str:
        steal = "/".join(str(s) for s in self.steal_ms)
        return (
            f"from sample {self.first} ({self.samples} late): reply {self.past_due_ms:.1f} ms "
            f"past due; sent {self.sent_late_ms:.1f} ms after due, the board "
            f"{self.board_behind_ms:.1f} ms behind the wall clock when it replied, the reply "
            f"read {self.reply_waited_ms:.1f} ms after it was written; steal {steal} ms "
            f"(CPU {'/'.join(str(i) for i in range(len(self.steal_ms)))})"
        )


@dataclass(frozen=True)
class TimingLog:
    ins: np.ndarray  # READ FEED CYCLE SIM N, ns
    outs: np.ndarray  # START END CYCLE SIM N, ns
    steal: np.ndarray  # AT, then ms per CPU

    @classmethod
    def read(cls, path: Path) -> TimingLog:
        rows: dict[str, list[list[int]]] = {"in": [], "out": [], "steal": []}
        for line in path.read_text().splitlines():
            kind, *values = line.split()
            if kind in rows:
                rows[kind].append([int(v) for v in values])
        return cls(*(np.array(rows[k] or np.zeros((0, 5)), dtype=np.int64) for k in rows))

    def steal_between(self, start_s: float, end_s: float) -> np.ndarray:
        if not len(self.steal):
            return np.zeros(0, dtype=np.int64)
        at = self.steal[:, 0] / 1e9
        return self.steal[(at >= start_s) & (at <= end_s), 1:].sum(axis=0)

    def late_stretches(
        self, request_bytes: int, late: np.ndarray, rtt_s: np.ndarray, sample_time: float
    ) -> list[LateStretch] | None:
        """Each stretch of late samples of a run of len(late) stop-and-wait SAMPLEs whose
        requests take `request_bytes` on the wire; None if the log does not hold one
        request a sample (one sent again)."""
        n = len(late)
        if not len(self.ins) or not len(self.outs):
            return None
        # A request's bytes may be fed in parts (read in parts, or held by the UART's
        # FIFO): the batches before the same reply are one request, read and fed at its
        # first's times.
        reply = np.searchsorted(self.outs[:, 0], self.ins[:, 1])
        first = np.flatnonzero(np.diff(reply, prepend=-1))
        size = np.add.reduceat(self.ins[:, 4], first)
        ins = self.ins[first][size == request_bytes]
        if len(ins) < n:
            return None
        ins = ins[-n:]  # the run's SAMPLEs, after the configuration's requests
        read_s = ins[:, 0] / 1e9
        # The loop sends each sample at its due time or after, never before: the earliest
        # read against the schedule is the loop's clock.
        schedule = np.arange(n) * sample_time
        due = np.min(read_s - schedule) + schedule
        arrived = read_s + rtt_s
        reply = np.minimum(np.searchsorted(self.outs[:, 0], ins[:, 1]), len(self.outs) - 1)
        stretches = []
        k = 0
        while k < n:
            if not late[k]:
                k += 1
                continue
            run = int(np.argmin(late[k:])) if not late[k:].all() else n - k
            out = self.outs[reply[k]]
            steal = self.steal_between(due[k] - sample_time, arrived[k] + _STEAL_LAG_S)
            stretches.append(
                LateStretch(
                    first=k,
                    samples=run,
                    past_due_ms=(arrived[k] - due[k]) * 1e3,
                    sent_late_ms=(read_s[k] - due[k]) * 1e3,
                    board_behind_ms=(out[0] - out[3]) / 1e6,
                    reply_waited_ms=(arrived[k] - out[1] / 1e9) * 1e3,
                    steal_ms=tuple(int(s) for s in steal),
                )
            )
            k += run
        return stretches
