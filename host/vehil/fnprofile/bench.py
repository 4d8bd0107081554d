"""What profiling costs: a 1,000-step MANF FIXED run on simavr with and without
`--functions`, wall time each (median of a few), and their ratio. A figure, not a test.

    python -m vehil.fnprofile.bench [--samples 1000] [--repeat 3]
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import tempfile
import time
from pathlib import Path

from rich.console import Console

from vehil import runner, scenario
from vehil.fnprofile import collect


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scenario", default="manf-hard-stop-fixed")
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    sc = scenario.load(args.scenario)
    sc = dataclasses.replace(sc, duration=args.samples * sc.sample_time)
    quiet = Console(quiet=True)
    plain, profiled = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.repeat):
            t = time.perf_counter()
            run = runner.run(sc, "simavr", recording=Path(tmp) / f"plain{i}.arrow", console=quiet)
            plain.append(time.perf_counter() - t)
            assert run.error is None, run.error
            t = time.perf_counter()
            res = collect.scenario_steps(sc, "simavr", folder=Path(tmp) / f"prof{i}")
            res.profile.function_stats()  # reading and naming the counts is part of the cost
            profiled.append(time.perf_counter() - t)
    a, b = statistics.median(plain), statistics.median(profiled)
    print(
        f"{sc.name}, {args.samples} steps, lockstep on simavr: {a:.2f} s without profiling, "
        f"{b:.2f} s with --functions (read and named): {b / a:.2f}x (target < 5x)"
    )


if __name__ == "__main__":
    main()
