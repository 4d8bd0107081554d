"""A scenario on an open link: the estimator configured, then every sample of a source
streamed through it, in order, surviving a board reset where it can.

Two pacings:
- lockstep: as fast as the board answers, with the board's RX window kept full;
- real time: one sample per sample time by the host clock, stop-and-wait like an
  ECU's task; a result that comes back after the next sample is due is late.
"""

from __future__ import annotations

import gc
import itertools
import os
import queue
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from vehil.errors import BoardError, BoardReset, VehilError
from vehil.link import Link, Reply
from vehil.scenario import Scenario
from vehil.source import Source

OnSample = Callable[[int, Reply, bool, np.ndarray], None]
# The samples answered so far, in order, as (inputs, outputs) chunks: from the recording.
History = Callable[[int], Iterator[tuple[np.ndarray, np.ndarray]]]

MAX_RESUMES = 3
# A real-time open-loop run makes this many samples' frames before its clock starts (a
# drive of up to 11 min at 100 Hz: all of it), on a thread that then keeps them this far
# ahead of the loop. Making a chunk (plant and float64 reference, ~1 s for STLQF's 4,096
# samples) inside the loop held it up: through the interpreter's lock, and at a real-time
# priority through the kernel, which stops a CPU's real-time threads for the rest of a
# second once they have used 95 % of it (a 1 ms sleep overshot by up to 169 ms).
AHEAD = 16 * 4096
# While a real-time loop runs, the thread making frames gives the interpreter up this
# often (Python's default, 5 ms, is half the slack of a 100 Hz loop).
SWITCH_INTERVAL_S = 2e-4
# The last stretch before a sample is due is waited out awake: a sleep may overshoot.
# Short, as the loop may run at a real-time priority, where spinning holds a core.
SPIN_S = 1e-3

Item = TypeVar("Item")


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
    with _real_time(realtime):
        if realtime and not source.closed:
            frames = _made_ahead(frames, AHEAD, fill_first=True)
        # The clock starts once the first sample exists (an open loop's real-time run: its
        # first AHEAD): making them is not the loop's time.
        if source.total > start:
            frames = itertools.chain([next(frames)], frames)
        yield from _paced(link, source, sc, realtime, frames, start)


def _paced(
    link: Link, source: Source, sc: Scenario, realtime: bool, frames: Iterator[bytes], start: int
) -> Iterator[tuple[int, Reply, bool, np.ndarray]]:
    spec, mode, T = sc.estimator, sc.mode, sc.sample_time
    t0 = time.perf_counter()
    for k, body in enumerate(frames, start):
        due = t0 + (k - start) * T
        while realtime and (wait := due - time.perf_counter()) > 0:
            time.sleep(wait - SPIN_S if wait > SPIN_S else 0)
        reply = link.request("SAMPLE", inputs=body)
        out = spec.decode_outputs(reply.fields()["outputs"], mode)
        source.after(k, out)
        yield k, reply, realtime and reply.sent_at + reply.rtt_s > due + T, out


@contextmanager
def _real_time(on: bool) -> Iterator[None]:
    """The interpreter set for a real-time loop: what exists now kept out of the garbage
    collector's full passes (a pass over a long run's heap takes milliseconds), and the
    interpreter switched between threads often."""
    if not on:
        yield
        return
    interval = sys.getswitchinterval()
    gc.collect()
    gc.freeze()
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    try:
        yield
    finally:
        sys.setswitchinterval(interval)
        gc.unfreeze()


def _below_the_loop() -> None:
    """Puts the calling thread one real-time priority below the loop's, if the loop runs
    under a real-time policy. At the same priority, a round-robin thread that is awake
    keeps its core for its whole time slice (100 ms): the loop, waking from its sleep with
    both cores taken, waited for it (stalls of 10-70 ms while a chunk was made). Below
    the loop but above the host's ordinary work, the thread is preempted by the loop and
    never kept off a core by that work while it holds the interpreter's lock (a priority
    inversion). Under ordinary scheduling it keeps the loop's niceness, for that reason."""
    if not hasattr(os, "sched_getscheduler"):  # not Linux
        return
    policy = os.sched_getscheduler(0)
    if policy in (os.SCHED_RR, os.SCHED_FIFO):
        prio = os.sched_getparam(0).sched_priority
        if prio > os.sched_get_priority_min(policy):
            # pid 0 is this thread on Linux: the loop's own thread keeps its priority
            os.sched_setscheduler(0, policy, os.sched_param(prio - 1))


def _made_ahead(items: Iterator[Item], depth: int, *, fill_first: bool = False) -> Iterator[Item]:
    """`items`, made on a thread of their own up to `depth` ahead of the consumer (with
    `fill_first`, the first is handed over once `depth` are made, or all); an exception
    raised making them is raised here, in order. The thread runs just below the loop
    (_below_the_loop)."""
    made: queue.Queue[tuple[bool, Item | BaseException | None]] = queue.Queue(maxsize=depth)
    stop = threading.Event()
    filled = threading.Event()

    def put(item: tuple[bool, Item | BaseException | None]) -> bool:
        while not stop.is_set():
            try:
                made.put(item, timeout=0.1)
                if made.full() or not item[0]:
                    filled.set()
                return True
            except queue.Full:
                filled.set()
        return False

    def make() -> None:
        try:
            _below_the_loop()
            for item in items:
                if not put((True, item)):
                    return
            put((False, None))
        except BaseException as exc:  # noqa: BLE001 - handed to the consumer
            put((False, exc))

    thread = threading.Thread(target=make, name="vehil-frames-ahead", daemon=True)
    thread.start()
    try:
        if fill_first:
            filled.wait()
        while True:
            more, item = made.get()
            if not more:
                if isinstance(item, BaseException):
                    raise item
                return
            yield item  # type: ignore[misc]
    finally:
        stop.set()
        thread.join()


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
