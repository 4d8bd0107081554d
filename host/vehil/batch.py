"""Several scenarios at once: one `vehil run` process (so one board) per job, their verdicts
gathered into one table; the exit status is the worst run's."""

from __future__ import annotations

import glob
import json
import subprocess
import sys
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from rich.markup import escape
from rich.table import Table

from vehil.compare import EXIT_ERROR, Verdict
from vehil.paths import runs_dir
from vehil.results import Case, case_from_folder, failed_case
from vehil.scenario import ScenarioError, find, scenario_dirs

GLOB_CHARS = frozenset("*?[")


def expand(patterns: Sequence[str]) -> list[Path]:
    """Scenario files for names, paths and globs; a glob matches .toml files, or when it
    matches none, shipped names (`'manf-*'`, `'braking/*'`). Each scenario once, in order."""
    found: list[Path] = []
    for pattern in patterns:
        if not GLOB_CHARS & set(pattern):
            paths = [find(pattern)]
        else:
            files = sorted(Path(p) for p in glob.glob(pattern, recursive=True))
            paths = [p for p in files if p.suffix == ".toml"]
            paths = paths or [
                p for d in scenario_dirs() for p in sorted(d.glob(f"**/{pattern}.toml"))
            ]
        if not paths:
            raise ScenarioError(
                f"{pattern!r} matches no scenario: give a .toml path, a glob of them, "
                "or a pattern of names from `vehil scenarios`"
            )
        found += [p for p in paths if p.resolve() not in {f.resolve() for f in found}]
    return found


@dataclass(frozen=True)
class Outcome:
    """One scenario's run as its own `vehil run --json` reported it."""

    scenario: str
    verdict: Verdict
    samples: int | None
    wall_s: float | None
    recording: str | None


def _run_one(path: Path, options: list[str], out: Path | None) -> Outcome:
    argv = [sys.executable, "-m", "vehil", "run", str(path), *options, "--json"]
    if out is not None:
        argv += ["--out", str(out / path.stem)]
    proc = subprocess.run(argv, capture_output=True, text=True)
    try:
        data: dict[str, Any] = json.loads(proc.stdout)
    except json.JSONDecodeError:
        # No figures: the run never started (bad scenario, board would not boot).
        said = proc.stderr.strip().splitlines()
        reason = said[-1] if said else f"exited with status {proc.returncode}"
        return Outcome(path.stem, Verdict("FAILED", reason, EXIT_ERROR), None, None, None)
    v = data["verdict"]
    verdict = Verdict(v["word"], v["reason"], proc.returncode)
    return Outcome(path.stem, verdict, data["samples"], data["wall_s"], data["recording"])


def run_all(
    paths: Sequence[Path], options: list[str], jobs: int, out: Path | None
) -> list[Outcome]:
    """Runs every scenario, `jobs` at a time (each its own process and board)."""
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        return list(pool.map(lambda p: _run_one(p, options, out), paths))


def run_dask(paths: Sequence[Path], out: Path | None, client: Any) -> tuple[list[Outcome], Path]:
    """Every scenario on the Dask cluster (native board), each writing its recording and
    report as `vehil run` does; their figures as one Arrow dataset (results/)."""
    from vehil import campaign
    from vehil.runner import default_recording_path
    from vehil.scenario import load

    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    root = out or runs_dir() / f"campaign-{stamp}"
    jobs = []
    for path in paths:
        sc = load(path)
        recording = (
            out / path.stem / "run.arrow" if out else default_recording_path(sc, campaign.BOARD)
        )
        jobs.append(campaign.Job(path.stem, sc, recording, report=True))
    done = campaign.run(client, jobs)
    outcomes = [
        Outcome(d.job.name, d.figures.verdict, d.samples, d.wall_s, str(d.job.recording))
        for d in done
    ]
    return outcomes, campaign.write_dataset(campaign.rows(done), root / "results")


def case(o: Outcome) -> Case:
    """The run's own figures.json, for JUnit and the HTML report."""
    if o.recording is None:
        return failed_case(o.scenario, o.verdict.reason)
    return case_from_folder(Path(o.recording).parent, o.scenario)


def worst(outcomes: Sequence[Outcome]) -> int:
    return max(o.verdict.exit_status for o in outcomes)


def table(outcomes: Sequence[Outcome], title: str) -> Table:
    t = Table(title=title)
    for col in ("scenario", "verdict", "why", "samples", "wall s", "recording"):
        t.add_column(col)
    for o in outcomes:
        style = "green" if o.verdict.passed else "red"
        t.add_row(
            o.scenario,
            f"[{style}]{o.verdict.word}[/]",
            escape(o.verdict.reason),
            f"{o.samples:,}" if o.samples is not None else "",
            f"{o.wall_s:.2f}" if o.wall_s is not None else "",
            o.recording or "",
        )
    return t


def to_json(o: Outcome) -> dict[str, Any]:
    return {
        "scenario": o.scenario,
        "verdict": o.verdict.word,
        "reason": o.verdict.reason,
        "exit_status": o.verdict.exit_status,
        "samples": o.samples,
        "wall_s": o.wall_s,
        "recording": o.recording,
    }
