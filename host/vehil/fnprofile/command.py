"""`vehil profile --functions` and `vehil run --profile`: profile, print, write."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console

from vehil.errors import VehilError
from vehil.fnprofile import collect, export, tables
from vehil.fnprofile.model import Profile
from vehil.paths import runs_dir


def show(
    console: Console,
    profile: Profile,
    title: str,
    folder: Path,
    result_cycles: np.ndarray | None = None,
) -> dict[str, Path]:
    for line in tables.summary_lines(profile, result_cycles):
        console.print(line)
    console.print(tables.flat_table(profile, title))
    console.print(tables.lines_table(profile))
    files = export.write_all(profile, folder, title, result_cycles)
    for kind, path in files.items():
        console.print(f"{kind:10s} {path}")
    return files


def _figures(args: argparse.Namespace, profile: Profile, files: dict[str, Path]) -> None:
    """With --json: the profile's figures on stdout rather than its tables."""
    if getattr(args, "json", False):
        args.json_out.append(tables.figures(profile, files))


def run_profile(console: Console, session: collect.Session, run: Any) -> None:
    """After `vehil run --profile`: the steps' profile beside the run's report."""
    if run.error:
        console.print("[yellow]no profile: the run did not complete[/]")
        return
    profile = session.read()
    sc = run.scenario
    title = f"{sc.name}: {sc.estimator.name} ({sc.mode}) step on {run.board}"
    show(console, profile, title, session.folder, run.cycles)
    report = session.folder.parent / "report.md"
    if report.exists():
        with report.open("a") as f:
            f.write(
                "\n## Where each step's cycles go\n\n![flame graph](profile/flame.png)\n\n"
                "Per function and source line: [profile/profile.md](profile/profile.md)\n"
            )


def profile_functions(args: argparse.Namespace, console: Console) -> int:
    from vehil import scenario

    board = args.board
    if args.ping is not None:
        per = args.per or "frame"
        if per not in ("frame", "exchange"):
            raise VehilError(f"--ping profiles per frame or per exchange, not per {per}")
        parts: dict[int, dict[str, float]] = {}
        bauds = [] if args.bauds == "all" else args.bauds.split(",")
        baud = int(bauds[0]) if len(bauds) == 1 else None  # one --bauds: the pings' baud
        window = args.window or 1
        for size in args.ping:
            folder = Path(args.out or runs_dir() / f"profile-functions-ping{size}-{per}-{board}")
            if args.out and len(args.ping) > 1:
                folder = folder / f"ping{size}"
            profile = collect.pings(
                board,
                size=size,
                count=args.count,
                what=per,
                folder=folder / "bridge",
                timeout_s=args.timeout,
                window=window,
                baud=baud,
            )
            title = f"{size}-byte PING on {board}, window {window}: " + (
                "the frame path (a frame's handling)"
                if per == "frame"
                else f"the whole firmware per exchange, {args.count} exchanges"
            )
            _figures(args, profile, show(console, profile, title, folder))
            if per == "exchange":
                parts[size] = tables.exchange_parts(profile)
        if parts:
            console.print(tables.parts_table(parts, board, window, baud))
        return 0
    if not args.scenario:
        raise VehilError("--functions needs a SCENARIO (or --ping SIZE for the link's frame path)")
    per = args.per or "step"
    if per == "exchange":
        raise VehilError("--per exchange is for --ping; a scenario's window: step, frame or run")
    sc = scenario.load(args.scenario)
    if args.samples:
        sc = dataclasses.replace(sc, duration=min(sc.duration, args.samples * sc.sample_time))
    per_what = "" if per == "step" else f"-per-{per}"
    folder = Path(
        args.out or runs_dir() / f"profile-functions-{sc.name}-{board}-{sc.mode.lower()}{per_what}"
    )
    result = collect.scenario_steps(
        sc, board, window=args.window, folder=folder / "bridge", timeout_s=args.timeout, per=per
    )
    title = f"{sc.name}: {sc.estimator.name} ({sc.mode}) {per} on {board}" + (
        ", stop-and-wait" if args.window == 1 else ", lockstep"
    )
    cycles = result.run.cycles if per == "step" else None
    _figures(args, result.profile, show(console, result.profile, title, folder, cycles))
    return 0
