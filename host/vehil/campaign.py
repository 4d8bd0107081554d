"""Campaigns on Dask distributed: many native-board runs handed to a cluster's workers.

A local cluster by default (one single-threaded worker process per core: the native
board is the firmware's C in the worker's own process), or a running scheduler's
address for a real cluster; there every worker needs this vehil installed and built
(`vehil build`), and the output folder must be one every worker can write (a shared
filesystem), since each run writes its recording where it runs. Each run is the same
runner.run as on one machine; its figures come back to the caller, which gathers them
into one table and one Arrow dataset (results/, Parquet: a row per run).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.dataset as pds

from vehil.errors import VehilError
from vehil.scenario import Scenario

BOARD = "native"  # the only board a worker can start itself


@dataclass(frozen=True)
class Job:
    """A run: its name in the campaign, the scenario, where its recording goes, and
    whether it writes its own report (report.md, figures.json, plots)."""

    name: str
    scenario: Scenario
    recording: Path
    report: bool = False


@dataclass(frozen=True)
class Done:
    """What comes back from a worker: the run's figures (vehil.compare.Figures), its
    wall time and samples, and where it wrote."""

    job: Job
    figures: Any
    samples: int
    wall_s: float
    worker: str


def _run(job: Job) -> Done:
    """On the worker."""
    from rich.console import Console

    from vehil import report, runner

    run = runner.run(job.scenario, BOARD, recording=job.recording, console=Console(quiet=True))
    if job.report and run.recording is not None:
        title = f"{job.name}: {job.scenario.estimator.name} ({job.scenario.mode}) on {BOARD}"
        report.write_run(run, report.run_context(run, title))
    return Done(job, run.figures, run.done, run.wall_s, f"{os.uname().nodename}:{os.getpid()}")


def check_board(board: str) -> None:
    if board != BOARD:
        raise VehilError(
            f"--board {board}: a Dask campaign runs on the native board only (a worker "
            "starts it in its own process); drop --dask/--scheduler, or use --board native"
        )


@contextmanager
def cluster(scheduler: str | None = None, workers: int | None = None) -> Iterator[Any]:
    """A Dask client: of the scheduler at `scheduler`, or of a local cluster with
    `workers` single-threaded worker processes (all cores by default)."""
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout="10s")
        except OSError as exc:
            raise VehilError(
                f"--scheduler {scheduler}: no Dask scheduler answers there ({exc}); start one "
                "(`dask scheduler`, then `dask worker ADDRESS` on each machine) or drop "
                "--scheduler for a local cluster"
            ) from None
        with client:
            yield client
        return
    n = workers or os.cpu_count() or 1
    if n < 1:
        raise VehilError(f"--workers {n}: give 1 or more")
    with (
        LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        ) as local,
        Client(local) as client,
    ):
        yield client


def run(
    client: Any, jobs: Sequence[Job], on_done: Callable[[Done], None] | None = None
) -> list[Done]:
    """Every job on the cluster; results in the jobs' order, `on_done` as each finishes."""
    from distributed import as_completed

    futures = client.map(_run, jobs, pure=False)
    index = {f.key: i for i, f in enumerate(futures)}
    found: list[Done | None] = [None] * len(jobs)
    for future in as_completed(futures):
        done = future.result()
        found[index[future.key]] = done
        if on_done is not None:
            on_done(done)
    return [d for d in found if d is not None]


def rows(done: Sequence[Done], extra: Sequence[dict[str, Any]] | None = None) -> pa.Table:
    """A row per run: name, verdict, why, samples, wall time, worker, recording, then every
    figure (`outputs.v.truth.rmse`...) and the `extra` columns given per run."""
    from vehil.results import flat

    table = []
    for i, d in enumerate(done):
        f = d.figures.to_json()
        table.append(
            {
                "name": d.job.name,
                "scenario": d.job.scenario.name,
                "verdict": d.figures.verdict.word,
                "reason": d.figures.verdict.reason,
                "samples": d.samples,
                "wall_s": d.wall_s,
                "worker": d.worker,
                "recording": str(d.job.recording),
                **(extra[i] if extra else {}),
                **{k: float(v) for k, v in flat(f).items() if not isinstance(v, str)},
            }
        )
    columns = list(dict.fromkeys(k for r in table for k in r))  # runs differ in figures
    return pa.Table.from_pylist([{k: r.get(k) for k in columns} for r in table])


def write_dataset(table: pa.Table, folder: Path) -> Path:
    """The campaign's table as an Arrow dataset (Parquet files) that pyarrow, pandas,
    polars and DuckDB open as one table: `pyarrow.dataset.dataset(folder)`."""
    pds.write_dataset(table, folder, format="parquet", existing_data_behavior="delete_matching")
    return folder
