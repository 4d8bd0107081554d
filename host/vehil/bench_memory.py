"""Host memory of long runs: a scenario stretched to N samples, each length run in a fresh
process, its peak resident set size printed beside the samples and the rate.

    python -m vehil.bench_memory --samples 1e6,1e7            # sine (passthrough) on native

A run streams its drive, reference, recording and metrics in chunks, so the peak should
not grow with N; `growth/sample` is (peak - peak of the shortest) / (N - shortest N).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from vehil.terminal import make_console


def _one(name: str, samples: int, board: str, out: Path) -> dict[str, Any]:
    from vehil import runner, scenario

    sc = scenario.load(name)
    sc = dataclasses.replace(sc, duration=samples * sc.sample_time)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    started = time.perf_counter()
    run = runner.run(sc, board, recording=out / "run.arrow", console=Console(quiet=True))
    wall = time.perf_counter() - started
    return {
        "samples": run.done,
        "verdict": run.figures.verdict.word,
        "wall_s": wall,
        "rss_start_mb": before / 1024,
        "rss_peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "recording_mb": (out / "run.arrow").stat().st_size / 2**20,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m vehil.bench_memory", description=__doc__)
    ap.add_argument("--samples", default="1e6,1e7", help="lengths, comma-separated")
    ap.add_argument("--scenario", default="sine")
    ap.add_argument("--board", default="native")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--one", type=int, help=argparse.SUPPRESS)  # the child: one length
    args = ap.parse_args(argv)
    if args.one:
        with tempfile.TemporaryDirectory() as tmp:
            print(json.dumps(_one(args.scenario, args.one, args.board, Path(tmp))))
        return 0
    rows = []
    for n in (int(float(x)) for x in args.samples.split(",")):
        argv_ = [sys.executable, "-m", "vehil.bench_memory", "--one", str(n)]
        argv_ += ["--scenario", args.scenario, "--board", args.board]
        proc = subprocess.run(argv_, capture_output=True, text=True, check=True)
        rows.append(json.loads(proc.stdout.splitlines()[-1]))
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    t = Table(title=f"host memory: {args.scenario} on {args.board}, one process per length")
    cols = ("samples", "verdict", "wall s", "samples/s", "RSS at start", "peak RSS")
    for col in (*cols, "growth/sample", "recording"):
        t.add_column(col, justify="right")
    first = rows[0]
    for r in rows:
        dn = r["samples"] - first["samples"]
        grow = (r["rss_peak_mb"] - first["rss_peak_mb"]) * 2**20 / dn if dn else None
        t.add_row(
            f"{r['samples']:,}",
            r["verdict"],
            f"{r['wall_s']:.0f}",
            f"{r['samples'] / r['wall_s']:,.0f}",
            f"{r['rss_start_mb']:.0f} MB",
            f"{r['rss_peak_mb']:.0f} MB",
            "-" if grow is None else f"{grow:.4f} B",
            f"{r['recording_mb']:.0f} MB",
        )
    make_console().print(t)
    return 0


if __name__ == "__main__":
    sys.exit(main())
