"""A real-time run's frames made on a thread of their own, ahead of the loop."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import pytest

from vehil.session import _made_ahead


def test_items_come_in_order_and_are_made_ahead_while_the_consumer_waits() -> None:
    made: list[int] = []

    def items() -> Iterator[int]:
        for i in range(10):
            made.append(i)
            yield i

    it = _made_ahead(items(), depth=4)
    assert next(it) == 0
    # The consumer busy elsewhere: the maker fills the queue meanwhile (the one taken, four
    # queued), however long a loaded host keeps its thread waiting (it can for 0.2 s).
    deadline = time.monotonic() + 30
    while len(made) < 5 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert len(made) >= 5
    assert list(it) == list(range(1, 10))


def test_an_error_making_them_is_raised_to_the_consumer_in_its_place() -> None:
    def items() -> Iterator[int]:
        yield 1
        raise ValueError("the plant diverged")

    it = _made_ahead(items(), depth=8)
    assert next(it) == 1
    with pytest.raises(ValueError, match="the plant diverged"):
        next(it)


def test_a_consumer_that_stops_early_stops_the_maker() -> None:
    def endless() -> Iterator[int]:
        i = 0
        while True:
            yield i
            i += 1

    before = threading.active_count()
    it = _made_ahead(endless(), depth=2)
    assert next(it) == 0
    it.close()  # the loop ended (a board error, say): the thread must not linger
    assert threading.active_count() == before


def _in_thread_at_rr(priority: int, body):  # noqa: ANN001, ANN202
    """body() on a thread of its own under SCHED_RR `priority` (pid 0: that thread alone);
    skips where the host does not allow real-time scheduling."""
    import os

    result: dict = {}

    def run() -> None:
        try:
            os.sched_setscheduler(0, os.SCHED_RR, os.sched_param(priority))
        except (PermissionError, AttributeError):
            result["skip"] = True
            return
        result["value"] = body()

    t = threading.Thread(target=run)
    t.start()
    t.join()
    if result.get("skip"):
        pytest.skip("real-time scheduling is not allowed here")
    return result["value"]


def test_the_maker_runs_one_real_time_priority_below_a_real_time_loop() -> None:
    """At the loop's own round-robin priority the maker, awake, kept a core for a whole
    100 ms slice while the loop waited for one."""
    import os

    def items() -> Iterator[tuple[int, int]]:
        yield os.sched_getscheduler(0), os.sched_getparam(0).sched_priority

    def loop() -> tuple[list[tuple[int, int]], int]:
        made = list(_made_ahead(items(), depth=2))
        return made, os.sched_getparam(0).sched_priority

    made, loop_priority = _in_thread_at_rr(10, loop)
    assert made == [(os.SCHED_RR, 9)]
    assert loop_priority == 10  # the loop's thread keeps its own


def test_filled_first_the_first_comes_once_all_are_made_or_the_queue_is_full() -> None:
    """A real-time run's clock starts on its first frame: a drive that fits the queue is
    all made by then, and nothing is made while the loop runs."""
    made: list[int] = []

    def items(n: int) -> Iterator[int]:
        for i in range(n):
            time.sleep(0.001)
            made.append(i)
            yield i

    it = _made_ahead(items(50), depth=100, fill_first=True)
    assert next(it) == 0
    assert len(made) == 50  # the whole drive
    assert list(it) == list(range(1, 50))
    made.clear()
    it = _made_ahead(items(500), depth=20, fill_first=True)
    assert next(it) == 0
    assert len(made) >= 20  # a full queue's worth
    it.close()
