"""PING round trips: latency of the link and the board's message core."""

from __future__ import annotations

import random
from dataclasses import dataclass

import numpy as np

from vehil.errors import LinkError, VehilError
from vehil.link import Link


@dataclass(frozen=True)
class PingSummary:
    count: int
    payload_bytes: str
    window: int
    baud: int
    f_cpu: int
    rtt_s: np.ndarray  # host wall clock, per exchange
    board_interval_s: np.ndarray  # board clock between consecutive PONGs
    clock_backsteps: int  # intervals left out because the board clock went backwards
    wire_bytes: float  # mean request + reply bytes on the wire
    lost: str | None = None  # why the PINGs stopped before the count, if they did

    @property
    def wire_limit_s(self) -> float:
        """Time the bytes of one exchange take on the wire at 10 bits per byte."""
        return self.wire_bytes * 10 / self.baud

    def percentiles(self, values: np.ndarray) -> dict[str, float]:
        return {
            "p50": float(np.percentile(values, 50)),
            "p95": float(np.percentile(values, 95)),
            "p99": float(np.percentile(values, 99)),
            "max": float(values.max()),
        }


def run_ping(
    link: Link,
    *,
    count: int,
    size: int | None,
    window: int = 1,
    seed: int = 0,
    partial: bool = False,
) -> PingSummary:
    """`count` PINGs with `size`-byte payloads (random sizes if None), checking every echo.
    `partial`: a link error after some PINGs ends them, and the summary covers those
    (`lost` says why) rather than raising."""
    assert link.info is not None
    rng = random.Random(seed)
    room = link.info.fields["max_body"] - 4  # the PONG adds a 4-byte timestamp
    if size is not None and not 0 <= size <= room:
        raise VehilError(f"--size {size}: the board echoes 0..{room} bytes (or -1: random sizes)")
    payloads = [
        rng.randbytes(size if size is not None else rng.randint(0, room)) for _ in range(count)
    ]
    rtts, stamps, wire = [], [], []
    replies = link.pipeline((("PING", {"payload": p}) for p in payloads), window=window)
    lost = None
    try:
        for i, (payload, reply) in enumerate(zip(payloads, replies, strict=False)):
            fields = reply.fields()
            if fields["payload"] != payload:
                raise LinkError(f"PING {i}: the echo differs from the payload sent")
            rtts.append(reply.rtt_s)
            stamps.append(fields["timestamp"])
            wire.append(reply.request_wire_bytes + reply.reply_wire_bytes)
    except LinkError as exc:
        if not (partial and rtts):
            raise
        lost = str(exc)
    f_cpu = link.info.f_cpu
    # The stamp is a 32-bit cycle count: differences wrap. QEMU raises Timer1's overflow
    # a moment after the count wraps, so its clock can step back 65,536 cycles.
    steps = np.mod(np.diff(np.array(stamps, dtype=np.int64)) + 2**31, 2**32) - 2**31
    intervals = steps[steps >= 0] / f_cpu
    return PingSummary(
        count=len(rtts),
        payload_bytes=str(size) if size is not None else f"0..{room} random",
        window=window,
        baud=int(link.info.fields["baud"]),
        f_cpu=f_cpu,
        rtt_s=np.array(rtts),
        board_interval_s=intervals,
        clock_backsteps=int((steps < 0).sum()),
        wire_bytes=float(np.mean(wire)),
        lost=lost,
    )
