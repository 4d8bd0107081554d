"""A run's host memory does not grow with its length: the drive, the reference, the
recording and the metrics stream in chunks (the figures for 10⁶ and 10⁷ samples come
from `python -m vehil.bench_memory`)."""

from __future__ import annotations

import dataclasses
import tracemalloc
from pathlib import Path

import pytest
from rich.console import Console

from vehil import runner, scenario


def _peak(samples: int, folder: Path) -> int:
    sc = scenario.load("sine")
    sc = dataclasses.replace(sc, duration=samples * sc.sample_time)
    tracemalloc.start()
    try:
        run = runner.run(sc, "native", recording=folder / "run.arrow", console=Console(quiet=True))
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert run.figures.verdict.word == "PASS" and run.done == samples
    return peak


@pytest.mark.long
def test_ten_times_the_samples_takes_no_more_memory(tmp_path: Path) -> None:
    _peak(1_000, tmp_path / "warm-up")  # what the first run imports is not the run's
    short = _peak(20_000, tmp_path / "short")
    long = _peak(200_000, tmp_path / "long")
    # Held whole, 180,000 more samples would take > 100 MB (they took ~0.6 KB each).
    assert long < short * 1.2 + 1_000_000, f"{short:,} B for 2e4 samples, {long:,} B for 2e5"
