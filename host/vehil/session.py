"""A scenario on an open link: the estimator configured, then every sample of a source
streamed through it, in order, surviving a board reset where it can.

Two pacings:
- lockstep: as fast as the board answers, with the board's RX window kept full;
- real time: one sample per sample time by the host clock, stop-and-wait like an
  ECU's task; a result that comes back after the next sample is due is late.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from vehil.errors import BoardError, BoardReset, VehilError
from vehil.link import Link, Reply
from vehil.scenario import Scenario
from vehil.source import Source

OnSample = Callable[[int, Reply, bool, np.ndarray], None]
# The samples answered so far, in order, as (inputs, outputs) chunks: from the recording.
History = Callable[[int], Iterator[tuple[np.ndarray, np.ndarray]]]

MAX_RESUMES = 3


@dataclass(frozen=True)
class Resume:
    """A board reset mid-run, and the run taken up again after it."""

    at_sample: int
    recovery_s: float
    reason: str


def configure(link: Link, sc: Scenario) -> None:
    spec = sc.estimator
    try:
        link.configure(spec.name, sc.mode, spec.encode_params(sc.params, sc.mode))
    except BoardError as exc:
        if exc.code != "BAD_PARAM" or not 0 <= exc.detail < len(spec.params):
            raise
        # The scenario range-checked every value, so the board refuses this one in this
        # numeric mode or together with the others: name it, and where the rules are.
        p = spec.params[exc.detail]
        raise BoardError(
            f"board refused CONFIG: BAD_PARAM (parameter {exc.detail}, {p.name} = "
            f"{sc.params[p.name]:g} {p.unit}, is in [{p.lo:g}, {p.hi:g}] but {spec.name} in "
            f"{sc.mode} refuses it with these parameters; what each mode takes: "
            f"firmware/lib/estimators/{spec.name}.h)",
            exc.code,
            exc.request,
            exc.detail,
        ) from None


def _stream(
    link: Link, source: Source, sc: Scenario, realtime: bool, window: int | None, start: int
) -> Iterator[tuple[int, Reply, bool, np.ndarray]]:
    """(k, reply, late, outputs) for each sample from `start`, in order. Lockstep open-loop
    runs keep the board's window full; real-time and closed-loop runs go one at a time."""
    spec, mode = sc.estimator, sc.mode
    frames: Iterator[bytes] = (spec.encode_inputs(u, mode) for u in source.inputs(start))
    if not realtime and not source.closed:
        requests = (("SAMPLE", {"inputs": body}) for body in frames)
        for k, reply in enumerate(link.pipeline(requests, window=window), start):
            yield k, reply, False, spec.decode_outputs(reply.fields()["outputs"], mode)
        return
    T = sc.sample_time
    # The clock starts once the first sample exists: making the drive's first chunk (its
    # plant and reference, ~0.8 s for STLQF's 60 s drive) is not the loop's time.
    frames = itertools.chain([next(frames)], frames) if source.total > start else frames
    t0 = time.perf_counter()
    for k, body in enumerate(frames, start):
        due = t0 + (k - start) * T
        while realtime and (wait := due - time.perf_counter()) > 0:
            time.sleep(min(wait, 0.002) if wait > 0.003 else 0)
        reply = link.request("SAMPLE", inputs=body)
        out = spec.decode_outputs(reply.fields()["outputs"], mode)
        source.after(k, out)
        yield k, reply, realtime and reply.sent_at + reply.rtt_s > due + T, out


def _catch_up(link: Link, sc: Scenario, answered: int, history: History) -> None:
    """A board that rebooted gets the estimator configured again and every sample it had
    answered; each answer must repeat the one it gave before, bit for bit."""
    spec = sc.estimator
    link.hello()
    configure(link, sc)
    k = 0
    for inputs, before in history(answered):
        frames = (spec.encode_inputs(u, sc.mode) for u in inputs)
        replies = link.pipeline(("SAMPLE", {"inputs": body}) for body in frames)
        for reply, was in zip(replies, before, strict=True):
            now = spec.decode_outputs(reply.fields()["outputs"], sc.mode)
            if now.tobytes() != np.asarray(was, dtype=np.float64).tobytes():
                raise VehilError(
                    f"the board rebooted and, given samples 0..{answered - 1} again, answered "
                    f"sample {k} differently: it cannot be resumed (non-deterministic estimator?)"
                )
            k += 1


def drive(
    link: Link,
    source: Source,
    sc: Scenario,
    *,
    realtime: bool = False,
    window: int | None = None,
    on_sample: OnSample | None = None,
    history: History | None = None,
    resumes: list[Resume] | None = None,
) -> int:
    """Streams the scenario; returns the samples answered. With `history` and `resumes`, a
    board reset in a lockstep run is survived: the board catches up from configuration
    on the samples it had answered (see _catch_up) and the run goes on."""
    configure(link, sc)
    answered = 0
    while True:
        try:
            for k, reply, late, out in _stream(link, source, sc, realtime, window, answered):
                answered += 1
                if on_sample is not None:
                    on_sample(k, reply, late, out)
            return answered
        except BoardReset as exc:
            if history is None or resumes is None or realtime or len(resumes) >= MAX_RESUMES:
                raise
            started = time.perf_counter()
            _catch_up(link, sc, answered, history)
            resumes.append(Resume(answered, time.perf_counter() - started, str(exc)))
