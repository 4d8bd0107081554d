"""Campaign throughput on Dask: a Monte Carlo sweep's drives per second on a local
cluster of 1, 2, ... worker processes (native board).

    python -m vehil.bench_campaign --drives 1000 --workers 1,2      # sweep-manf, 4 s drives

Each count gets a fresh cluster; the time is the sweep's, from the first drive handed
out to the last figures gathered (the cluster's start is printed apart). Wall-clock
figures: on a shared machine they move with the load.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from vehil import campaign, scenario, sweep
from vehil.terminal import make_console


def _one(sc: scenario.Scenario, drives: int, workers: int, out: Path) -> dict[str, Any]:
    found = sweep.perturbations(sc, {})
    started = time.perf_counter()
    with campaign.cluster(workers=workers) as client:
        up = time.perf_counter() - started
        t0 = time.perf_counter()
        s = sweep.run(sc, found, drives, "native", out=out, client=client)
        wall = time.perf_counter() - t0
    runs = drives + 1  # and the nominal one
    return {
        "workers": workers,
        "drives": runs,
        "samples_per_drive": s.nominal.figures.samples,
        "cluster_start_s": up,
        "wall_s": wall,
        "drives_per_s": runs / wall,
        "verdicts": s.verdicts(),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m vehil.bench_campaign", description=__doc__)
    ap.add_argument("--scenario", default="sweep-manf", help="a scenario with a [sweep] table")
    ap.add_argument("--drives", type=int, default=1000)
    ap.add_argument("--workers", default=f"1,2,{os.cpu_count()}", help="counts, comma-separated")
    ap.add_argument("--duration", type=float, default=None, help="each drive's length, s")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    sc = scenario.load(args.scenario)
    if args.duration:
        sc = dataclasses.replace(sc, duration=args.duration)
    rows = []
    counts = list(dict.fromkeys(int(w) for w in args.workers.split(",")))
    for n in counts:
        with tempfile.TemporaryDirectory() as tmp:
            rows.append(_one(sc, args.drives, n, Path(tmp)))
        Console(stderr=True).print(f"{n} workers: {rows[-1]['drives_per_s']:.2f} drives/s")
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    t = Table(title=f"{sc.name} on native through Dask ({os.cpu_count()} cores on this machine)")
    for col in ("workers", "drives", "samples each", "cluster start s", "wall s", "drives/s"):
        t.add_column(col, justify="right")
    t.add_column("vs 1 worker", justify="right")
    base = rows[0]["drives_per_s"]
    for r in rows:
        t.add_row(
            str(r["workers"]),
            f"{r['drives']:,}",
            f"{r['samples_per_drive']:,}",
            f"{r['cluster_start_s']:.1f}",
            f"{r['wall_s']:.1f}",
            f"{r['drives_per_s']:.2f}",
            f"{r['drives_per_s'] / base:.2f}x",
        )
    make_console().print(t)
    return 0


if __name__ == "__main__":
    sys.exit(main())
