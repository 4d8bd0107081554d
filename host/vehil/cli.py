"""The `vehil` command line."""

from __future__ import annotations

import argparse
import contextlib
import errno
import json
import signal
import sys
import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rich.markup import escape
from rich.table import Table

from vehil.boards import (
    DEFAULT_BOARD,
    LABGRID_PREFIX,
    VIRTUAL_BOARDS,
    Board,
    BoardOptions,
    SimavrOptions,
    make_board,
    open_board,
)
from vehil.boards.base import DEFAULT_BAUD, image_boot_baud
from vehil.errors import LinkError, NotComparable, Terminated, VehilError
from vehil.link import BoardInfo
from vehil.paths import runs_dir
from vehil.ping import PingSummary, run_ping
from vehil.terminal import make_console

if TYPE_CHECKING:
    from vehil.boards.labgrid import LabgridOptions

console = make_console()


def _add_json_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--json", action="store_true", help="print the figures as JSON on stdout, not tables"
    )


def _show(args: argparse.Namespace, table: Table, data: Any) -> None:
    """A table for people or, with --json, its figures for programs."""
    if getattr(args, "json", False):
        args.json_out.append(data)
    else:
        console.print(table)


def _add_board_options(p: argparse.ArgumentParser, default: str = DEFAULT_BOARD) -> None:
    p.add_argument(
        "--board",
        default=default,
        help=f"{', '.join(VIRTUAL_BOARDS)}, labgrid:PLACE (or labgrid:ENV.yaml), or a serial "
        f"port / pyserial URL (default {default})",
    )
    p.add_argument(
        "--baud",
        type=_above_zero(int),
        default=None,
        help="switch the link to this baud rate once connected",
    )
    _add_boot_baud_option(p)
    p.add_argument(
        "--timeout", type=_above_zero(float), default=2.0, help="seconds to wait for each reply"
    )
    p.add_argument(
        "--faults",
        default=None,
        help="inject link faults once the board is up: drop=P,flip=P,dup=P,insert=P "
        "(per byte, both ways), delay_ms=D, reboot_after=N (writes), seed=N",
    )
    p.add_argument(
        "--acquire-timeout",
        type=float,
        default=60.0,
        metavar="S",
        help="labgrid:PLACE boards: how long to wait for a place someone else holds (default 60)",
    )
    _add_json_option(p)


_BOOT_BAUD_BUILT = (
    "the firmware's UART boots at this rate, not 1000000: for a USB-serial adapter that "
    "cannot run 1 Mbaud (the host opens the link at the image's rate)"
)


def _add_boot_baud_option(
    p: argparse.ArgumentParser,
    what: str = "the rate the board's firmware boots at, where the link opens (default: the "
    "image's, 1000000 unless built with `vehil build --boot-baud`)",
) -> None:
    p.add_argument("--boot-baud", type=_above_zero(int), default=None, metavar="BAUD", help=what)


def _add_run_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--realtime", action="store_true", help="pace samples at the sample time")
    p.add_argument("--out", default=None, help="folder for run.arrow and the report")


def _options(args: argparse.Namespace) -> BoardOptions:
    return BoardOptions(
        timeout_s=args.timeout, faults=args.faults, boot_baud=args.boot_baud, baud=args.baud
    )


def _labgrid(args: argparse.Namespace) -> LabgridOptions | None:
    if not (args.board or "").startswith(LABGRID_PREFIX):
        return None
    from vehil.boards.labgrid import LabgridOptions

    return LabgridOptions(wait_s=getattr(args, "acquire_timeout", 60.0))


def _add_result_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--junit",
        metavar="FILE",
        help="also write JUnit XML: each run a test case, its figures as properties",
    )
    p.add_argument(
        "--html",
        metavar="FILE",
        help="also write one self-contained HTML report (verdicts, figures, plots, details)",
    )
    p.add_argument(
        "--baseline",
        metavar="PATH",
        help="the HTML report's trend: a run's figures.json, an earlier report's "
        "results.json, or a folder of runs",
    )


def _add_dask_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--dask",
        action="store_true",
        help="hand the runs (native board) to Dask distributed: a local cluster, or --scheduler",
    )
    p.add_argument(
        "--workers", type=int, default=None, help="--dask: local worker processes (all cores)"
    )
    p.add_argument(
        "--scheduler", metavar="ADDRESS", help="a running Dask scheduler (tcp://host:8786)"
    )


@contextlib.contextmanager
def _dask_client(args: argparse.Namespace) -> Iterator[Any]:
    """A Dask client if the command was asked to use one, else None (runs stay here)."""
    if not (args.dask or args.scheduler):
        if args.workers is not None:
            raise VehilError("--workers is the local Dask cluster's: give --dask too")
        yield None
        return
    from vehil import campaign

    campaign.check_board(args.board)
    with campaign.cluster(args.scheduler, args.workers) as client:
        console.print(
            f"Dask: {len(client.scheduler_info()['workers'])} workers at {client.scheduler.address}"
        )
        yield client


def _baseline(args: argparse.Namespace) -> dict[str, Any] | None:
    """Read before any run: a baseline that cannot be read stops nothing half-way."""
    from vehil import results

    if args.baseline and not args.html:
        raise VehilError("--baseline is the HTML report's trend: give --html FILE too")
    return results.load_baseline(Path(args.baseline)) if args.baseline else None


def _write_results(
    args: argparse.Namespace,
    cases: Sequence[Any],
    title: str,
    baseline: dict[str, Any] | None,
    images: Sequence[Path] = (),
) -> None:
    """JUnit XML and the HTML report (with results.json beside it), as asked."""
    from vehil import results

    if args.junit:
        console.print(f"junit     {results.junit(cases, 'vehil', Path(args.junit))}")
    if args.html:
        page = results.write_html(cases, title, Path(args.html), baseline, images)
        results.write_json(cases, title, page.with_suffix(".json"))
        console.print(f"html      {page}")


def _board(args: argparse.Namespace) -> Board:
    return make_board(args.board, _options(args), labgrid=_labgrid(args))


def _connect(args: argparse.Namespace):  # noqa: ANN202
    return open_board(args.board, _options(args), labgrid=_labgrid(args))


def info_table(board: str, info: BoardInfo) -> Table:
    f = info.fields
    t = Table(title=f"{board}: vehil firmware {info.firmware_version}", show_header=False)
    t.add_column(style="bold")
    t.add_column()
    t.add_row("protocol", f"v{f['protocol']}")
    t.add_row("clock", f"{f['f_cpu'] / 1e6:g} MHz")
    t.add_row("baud", f"{f['baud']}")
    t.add_row("max frame body", f"{f['max_body']} B")
    t.add_row("RX buffer", f"{f['rx_buffer']} B")
    t.add_row("free RAM", f"{f['free_ram']} B")
    t.add_row("boot", f"#{f['boot_count']}, reset cause {info.reset_cause}")
    for e in info.estimators:
        io = "any length" if e.n_inputs == 0 else f"{e.n_inputs} in, {e.n_outputs} out"
        t.add_row(f"estimator {e.id}", f"{e.name} ({'/'.join(e.modes)}; {io}; {e.n_params} params)")
    return t


def ping_table(board: str, s: PingSummary) -> Table:
    t = Table(
        title=f"{board}: {s.count} PINGs, payload {s.payload_bytes} B, window {s.window}, "
        f"{s.baud} baud",
    )
    for col in ("", "p50", "p95", "p99", "max"):
        t.add_column(col, justify="right")
    rtt = s.percentiles(s.rtt_s)
    t.add_row("round trip, host clock (ms)", *(f"{v * 1e3:.3f}" for v in rtt.values()))
    if len(s.board_interval_s):
        b = s.percentiles(s.board_interval_s)
        t.add_row("per exchange, board clock (ms)", *(f"{v * 1e3:.3f}" for v in b.values()))
    t.caption = (
        f"wire limit {s.wire_limit_s * 1e3:.3f} ms for {s.wire_bytes:.0f} B at 10 bits/byte; "
        f"p50 round trip = {rtt['p50'] / s.wire_limit_s:.2f} x wire limit; "
        + (f"then lost: {s.lost}" if s.lost else "no loss")
    )
    if s.clock_backsteps:
        t.caption += (
            f"; the board clock went backwards {s.clock_backsteps} times "
            "(those intervals are left out)"
        )
    return t


def _ping_figures(s: PingSummary) -> dict[str, Any]:
    figures = {k: v for k, v in vars(s).items() if k not in ("rtt_s", "board_interval_s")}
    figures["rtt_s"] = s.percentiles(s.rtt_s)
    if len(s.board_interval_s):
        figures["board_interval_s"] = s.percentiles(s.board_interval_s)
    figures["wire_limit_s"] = s.wire_limit_s
    return figures


def cmd_build(args: argparse.Namespace) -> int:
    from vehil.build import build

    parts = tuple(args.only) if args.only else None
    for part, path in build(parts, boot_baud=args.boot_baud, verbose=args.verbose).items():
        console.print(f"[green]built[/] {part}: {path}")
        if part == "firmware":
            from vehil.build.budget import budget

            console.print(f"  {budget(path).summary()}")
    return 0


def cmd_new(args: argparse.Namespace) -> int:
    from vehil import skeleton

    if args.what == "project":
        written = skeleton.new_project(Path(args.name or "."), args.project_name)
        then = "cd into it, then `vehil new estimator NAME`"
    else:
        if not args.name:
            raise skeleton.SkeletonError("give the estimator's name: vehil new estimator NAME")
        written = (
            skeleton.new_wrapper(args.name, Path(args.wrap), args.title)
            if args.wrap
            else skeleton.new_estimator(args.name, args.title)
        )
        mode = "f32" if args.wrap else "fixed"
        then = f"`vehil build`, then `vehil run {args.name}/sine-{mode} --board simavr` or `pytest`"
    for path in written:
        console.print(f"[green]wrote[/] {path}")
    console.print(f"next: {then}")
    return 0


def cmd_info(args: argparse.Namespace) -> int:
    with _connect(args) as link:
        assert link.info is not None
        stats = link.stats()
        _show(args, info_table(args.board, link.info), {"info": link.info.fields, "stats": stats})
        if stats["stack_size"]:
            used = stats["stack_size"] - stats["stack_unused"]
            console.print(f"stack high-water mark: {used} of {stats['stack_size']} B")
    return 0


def cmd_flash(args: argparse.Namespace) -> int:
    from vehil import flash
    from vehil.boards import ports_seen
    from vehil.boards.serialport import SerialBoard
    from vehil.errors import NoPort

    # the image's boot rate, where the link to it opens (an Intel HEX does not say it)
    boot = args.boot_baud
    if boot is None and args.image:
        given = Path(args.image)
        boot = image_boot_baud(given) if given.suffix == ".elf" else DEFAULT_BAUD
    options = BoardOptions(timeout_s=args.timeout, boot_baud=boot or DEFAULT_BAUD)
    if args.port:
        board: Board = SerialBoard(args.port, options)
    elif args.board:
        board = make_board(args.board, options, labgrid=_labgrid(args))
    else:
        raise NoPort(
            f"give the board's port (--port /dev/ttyACM0; ports seen: {ports_seen()}) "
            "or --board simavr-bootloader"
        )
    flash.check_target(board, args.baud, args.boot_baud)
    if args.image:
        image = Path(args.image)
        if image.suffix == ".elf":
            image = flash.to_hex(image, flash.FLASH_DIR / f"{image.stem}.hex")
    else:
        image = flash.firmware_hex(args.env, boot_baud=args.boot_baud)
    with flash.flashed(board, image, baud=args.baud) as (result, link):
        console.print(
            f"[green]flashed[/] {result.image} to {result.port}: {result.bytes:,} B written "
            f"in {result.write_s:.2f} s, verified in {result.verify_s:.2f} s "
            f"(avrdude {result.seconds:.2f} s in all)"
        )
        assert link.info is not None
        _show(
            args,
            info_table(board.name, link.info),
            {"flashed": vars(result), "info": link.info.fields},
        )
    return 0


def cmd_ping(args: argparse.Namespace) -> int:
    with _connect(args) as link:
        summary = run_ping(link, count=args.count, size=args.size, window=args.window, partial=True)
        _show(args, ping_table(args.board, summary), _ping_figures(summary))
    if summary.lost:
        raise LinkError(f"the PINGs stopped after {summary.count:,} of {args.count:,}")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    """What vehil does, in one run: a board boots, answers, and streams samples."""
    import struct

    import numpy as np

    with _connect(args) as link:
        assert link.info is not None
        _show(args, info_table(args.board, link.info), {"info": link.info.fields})
        pings = run_ping(link, count=1000, size=16)
        _show(args, ping_table(args.board, pings), {"ping": _ping_figures(pings)})
        link.configure("passthrough", "F32")
        samples = [struct.pack("<4f", k, 2 * k, 3 * k, 4 * k) for k in range(args.samples)]
        replies = list(link.pipeline(("SAMPLE", {"inputs": x}) for x in samples))
        mismatched = sum(r.fields()["outputs"] != x for r, x in zip(replies, samples, strict=True))
        cycles = np.array([r.fields()["cycles"] for r in replies])
        rtt = np.array([r.rtt_s for r in replies])
        console.print(
            f"passthrough: {len(replies)} samples streamed, {mismatched} mismatched; "
            f"step {np.median(cycles):.0f} cycles median ({cycles.max()} max); "
            f"round trip p50 {np.median(rtt) * 1e3:.3f} ms with up to "
            f"{link.info.rx_buffer} B in flight"
        )
        stats = link.stats()
        console.print(
            f"board counters: {stats['rx_frames']} frames in, {stats['tx_frames']} out, "
            f"{stats['crc_errors']} CRC errors, {stats['overruns']} overruns; stack high-water "
            f"{stats['stack_size'] - stats['stack_unused']} of {stats['stack_size']} B"
        )
        return 1 if mismatched else 0


def _open_recording(path_str: str):  # noqa: ANN202
    from vehil import record

    path = Path(path_str)
    return record.read(path / "run.arrow" if path.is_dir() else path)


def _finish_run(
    args: argparse.Namespace,
    run,
    title: str,
    input_note: str | None = None,  # noqa: ANN001
) -> int:
    """Evaluates a run once; the console, report.md, figures.json and the exit status
    all say its verdict."""
    from vehil import report

    figures = run.figures
    sc = run.scenario
    rate = run.done / run.wall_s if run.wall_s else 0.0
    context = report.run_context(run, title, input_note)
    _show(args, report.summary_table(figures, title), {**context, **figures.to_json()})
    expected = f"{run.expected:,}" if run.expected is not None else "?"
    console.print(
        f"{run.done:,} of {expected} samples in {run.wall_s:.2f} s "
        f"({rate:,.0f} samples/s, {'real time' if run.realtime else 'lockstep'}"
        f"{', closed loop' if sc.closed_loop else ''}); {run.ended}"
    )
    for r in run.resumes:
        console.print(
            f"[yellow]{r.reason}[/]: before sample {r.at_sample:,} it caught up on the samples "
            f"before (each answer checked) and the run went on after {r.recovery_s * 1e3:.0f} ms"
        )
    if run.recording is not None:
        md = report.write_run(run, context)
        console.print(f"recording {run.recording}\nreport    {md}")
    for note in context["log_notes"] or ():
        console.print(f"[yellow]log:[/] {note}")
    if input_note:
        console.print(f"[bold yellow]input cut short:[/] {input_note}")
    console.print(report.verdict_line(figures))
    return figures.verdict.exit_status


def _forwarded_run_options(args: argparse.Namespace) -> list[str]:
    """The options of `vehil run` that each of several runs gets as given."""
    options = ["--board", args.board, "--timeout", str(args.timeout)]
    options += ["--acquire-timeout", str(args.acquire_timeout)]
    given = {"--baud": args.baud, "--boot-baud": args.boot_baud, "--faults": args.faults}
    given["--window"] = args.window
    for flag, value in given.items():
        if value is not None:
            options += [flag, str(value)]
    return options + ["--realtime"] * args.realtime + ["--profile"] * args.profile


def cmd_run_several(args: argparse.Namespace) -> int:
    from vehil import batch

    paths = batch.expand(args.scenario)
    if args.dask or args.scheduler:
        return _run_on_dask(args, paths)
    if len(paths) == 1 and args.jobs == 1:
        args.scenario = [str(paths[0])]
        return cmd_run(args)
    if args.jobs < 1:
        raise VehilError(f"--jobs {args.jobs}: give 1 or more boards to run on")
    baseline = _baseline(args)
    console.print(f"{len(paths)} scenarios on {args.board}, {args.jobs} at a time")
    outcomes = batch.run_all(
        paths, _forwarded_run_options(args), args.jobs, Path(args.out) if args.out else None
    )
    title = f"{len(paths)} scenarios on {args.board} ({args.jobs} at a time)"
    _show(args, batch.table(outcomes, title), [batch.to_json(o) for o in outcomes])
    _write_results(args, [batch.case(o) for o in outcomes], title, baseline)
    return batch.worst(outcomes)


def _run_on_dask(args: argparse.Namespace, paths: list[Path]) -> int:
    from vehil import batch

    given = {"--realtime": args.realtime, "--faults": args.faults, "--window": args.window}
    given |= {"--profile": args.profile, "--baud": args.baud, "--boot-baud": args.boot_baud}
    if used := [flag for flag, v in given.items() if v]:
        raise VehilError(f"{', '.join(used)}: not for runs on Dask (native board, lockstep)")
    baseline = _baseline(args)
    out = Path(args.out) if args.out else None
    with _dask_client(args) as client:
        outcomes, dataset = batch.run_dask(paths, out, client)
    title = f"{len(paths)} scenarios on {args.board} (Dask)"
    _show(args, batch.table(outcomes, title), [batch.to_json(o) for o in outcomes])
    console.print(f"dataset   {dataset}")
    _write_results(args, [batch.case(o) for o in outcomes], title, baseline)
    return batch.worst(outcomes)


def cmd_run(args: argparse.Namespace) -> int:
    from vehil import runner, scenario

    sc = scenario.load(args.scenario[0])
    baseline = _baseline(args)
    recording = Path(args.out) / "run.arrow" if args.out else None
    board, profiled = _board(args), None
    if args.profile:
        from vehil.fnprofile import collect

        recording = recording or runner.default_recording_path(sc, args.board)
        profiled = collect.session(args.board, "step", recording.parent / "profile")
        board = profiled.board(args.board, _options(args))
    run = runner.run(
        sc,
        board,
        realtime=args.realtime,
        window=args.window,
        recording=recording,
        timeout_s=args.timeout,
    )
    title = f"{sc.name}: {sc.estimator.name} ({sc.mode}) on {args.board}"
    code = _finish_run(args, run, title)
    if run.recording is not None:
        from vehil.results import case_from_folder

        _write_results(args, [case_from_folder(run.recording.parent, sc.name)], title, baseline)
    if profiled is not None:
        from vehil.fnprofile.command import run_profile

        run_profile(console, profiled, run)
    return code


def _replayed_cut(log_path: Path, accept: bool) -> str | None:
    """A recording holding less than its drive is refused, or with `accept` said loudly."""
    from vehil import record

    cut = record.read(log_path).cut_short
    if cut is None:
        return None
    note = f"{log_path}: {cut}; only that part of the drive is replayed"
    if not accept:
        raise record.RecordingError(
            f"{log_path}: {cut}: replaying it would check part of a drive as if it were the "
            "whole; give --accept-truncated to replay the part there is"
        )
    console.print(f"[bold yellow]warning:[/] {note}")
    return note


def cmd_replay(args: argparse.Namespace) -> int:
    import tomllib

    from vehil import runner, scenario
    from vehil.csvlog import LogError

    sc_path = scenario.find(args.scenario)
    data = tomllib.loads(sc_path.read_text())
    log_path = Path(args.log).resolve()
    if log_path.is_dir():
        log_path = log_path / "run.arrow"
    fmt = scenario.LOG_SUFFIXES.get(log_path.suffix.lower())
    if fmt is None:
        known = ", ".join(scenario.LOG_SUFFIXES)
        raise VehilError(f"{log_path}: unknown log type; give a file ending in {known}")
    note = _replayed_cut(log_path, args.accept_truncated) if fmt == "vehil" else None
    # A recording carries the estimator's inputs by name: the scenario's [log] mapping
    # is for the log it was written for, not for this.
    log = {} if fmt == "vehil" else dict(data.get("log", {}))
    log.update(path=str(log_path), format=fmt)
    data.pop("plant", None)
    data["log"] = log
    data.setdefault("scenario", {}).pop("duration", None)
    # A closed loop's recording holds the inputs its plant measured: replayed, they are fed
    # as they were, open loop (the board's outputs no longer steer a plant).
    data["scenario"].pop("closed_loop", None)
    sc = scenario.parse(data, f"{sc_path} (replaying {log_path.name})", sc_path.resolve())
    recording = Path(args.out) / "run.arrow" if args.out else None
    board = _board(args)
    try:
        run = runner.run(
            sc, board, realtime=args.realtime, recording=recording, timeout_s=args.timeout
        )
    except LogError as exc:
        unmapped = fmt != "vehil" and not log.get("columns")
        if not unmapped or not any(f": no {w} " in str(exc) for w in ("column", "channel")):
            raise
        raise LogError(
            f"{exc} ({sc_path.name} has no [log.columns] saying which column feeds each input "
            f"of {sc.estimator.name}: docs/logs.md, 'Mapping inputs')"
        ) from None
    title = f"replay of {log_path.name}: {sc.estimator.name} on {args.board}"
    return _finish_run(args, run, title, note)


def cmd_compare(args: argparse.Namespace) -> int:
    from vehil import compare, report

    a, b = _open_recording(args.run_a), _open_recording(args.run_b)
    for rec in (a, b):
        if rec.truncated:
            console.print(f"[yellow]warning:[/] {rec.path}: {rec.truncated}")
    if why := compare.drive_difference(a, b):
        names = [r.header.get("scenario", {}).get("name", "?") for r in (a, b)]
        raise NotComparable(
            f"{a.path} (A, scenario {names[0]!r}) and {b.path} (B, {names[1]!r}) are not runs "
            f"of one drive: {why}. vehil compare sets two runs of one drive side by side "
            "(board vs board, build vs build): compare A with a run of its own scenario"
        )
    d = compare.diff_runs(compare.series_from_recording(a), compare.series_from_recording(b))
    within = all(o["max_abs"] <= args.atol for o in d["outputs"].values())
    same_length = d["lengths"][0] == d["lengths"][1]
    same = d["identical"] or (bool(d["outputs"]) and args.atol > 0 and within and same_length)
    if not d["outputs"]:
        only_a, only_b = d["only_in"]
        says = (
            f"the runs share no outputs: {a.path} has {', '.join(only_a) or 'none'}, "
            f"{b.path} has {', '.join(only_b) or 'none'}"
        )
    else:
        says = "same results" if same else "results differ"
    if not same_length:
        says += "; " + _shorter_run(a, b)
    _show(args, report.diff_table(d, str(a.path), str(b.path)), {**d, "verdict": says})
    console.print(f"[green]{says}[/]" if same else f"[bold red]{says}[/]")
    return 0 if same else 1


def _shorter_run(a, b) -> str:  # noqa: ANN001
    """Which of two recordings holds fewer samples, and how its run ended."""
    short, other = (a, b) if len(a) < len(b) else (b, a)
    label = "A" if short is a else "B"
    end = short.end or {}
    how = end.get("ended") or ("cut short" if short.truncated else "not recorded")
    error = (end.get("error") or "").splitlines()
    return (
        f"{label} holds {len(short):,} samples, the other {len(other):,} (its run: {how}"
        + (f": {error[0]}" if error else "")
        + ")"
    )


def cmd_scenarios(args: argparse.Namespace) -> int:
    from vehil import scenario

    t = Table(title="scenarios (the project's, then vehil's)")
    columns = ("name", "estimator", "mode", "source", "duration", "title")
    for col in columns:
        t.add_column(col)
    rows: list[dict[str, Any]] = []
    for path in scenario.shipped():
        name = scenario.scenario_name(path)
        try:
            sc = scenario.load(path)
        except VehilError as exc:
            t.add_row(name, f"[red]{escape(str(exc))}[/]", "", "", "", "")
            rows.append({"name": name, "error": str(exc)})
            continue
        source = f"plant {sc.plant}" if sc.plant else f"log {sc.log.path.name}"  # type: ignore[union-attr]
        row = (name, sc.estimator.name, sc.mode, source, f"{sc.duration:g} s", sc.title)
        t.add_row(*row)
        rows.append({**dict(zip(columns, row, strict=True)), "duration": sc.duration})
    _show(args, t, rows)
    return 0


def cmd_estimators(args: argparse.Namespace) -> int:
    from vehil import catalog, estimators

    return _catalog(
        args,
        estimators.estimators(),
        "estimator",
        catalog.estimators_table,
        catalog.estimator_tables,
        catalog.estimator_data,
    )


def cmd_plants(args: argparse.Namespace) -> int:
    from vehil import catalog, plants

    return _catalog(
        args,
        plants.plants(),
        "plant",
        catalog.plants_table,
        catalog.plant_tables,
        catalog.plant_data,
    )


def _catalog(
    args: argparse.Namespace,
    items: dict[str, Any],
    what: str,
    table: Callable[[Iterable[Any]], Table],
    tables: Callable[[Any], list[Table]],
    data: Callable[[Any], dict[str, Any]],
) -> int:
    """Every item in one table, or with a name, that one in full."""
    if not args.name:
        _show(args, table(items.values()), [data(i) for i in items.values()])
    elif args.name not in items:
        raise VehilError(f"no {what} {args.name!r}; known: {', '.join(sorted(items))}")
    else:
        _show_all(args, tables(items[args.name]), data(items[args.name]))
    return 0


def _show_all(args: argparse.Namespace, tables: Sequence[Table], data: Any) -> None:
    if getattr(args, "json", False):
        args.json_out.append(data)
    else:
        for t in tables:
            console.print(t)


def cmd_reproduce(args: argparse.Namespace) -> int:
    from vehil import papers

    known = papers.papers()
    if args.paper not in known:
        raise VehilError(f"no paper {args.paper!r}; known: {', '.join(sorted(known)) or 'none'}")
    return int(known[args.paper].reproduce(console, args.board))


def cmd_tolerances(args: argparse.Namespace) -> int:
    from vehil import scenario, tolerances

    sc = scenario.load(args.scenario)
    prepared = tolerances.prepare(sc)  # a log's drive is as long as the log
    found = tolerances.budget(sc, args.trials, args.safety, args.roundoff, prepared)
    t = Table(
        title=f"{sc.name} ({sc.mode}, T = {sc.sample_time:g} s, "
        f"{len(prepared.reference):,} steps): "
        f"the rounding's reach and the tolerance it suggests (× {args.safety:g})"
    )
    for col in ("output", "reach (max |Δ|)", "suggested abs", "scenario's abs"):
        t.add_column(col, justify="right" if col != "output" else "left")
    rows = []
    for name, b in found.items():
        shipped = "-" if b.shipped is None else f"{b.shipped:.2g}"
        t.add_row(name, f"{b.reach:.2e}", f"{b.tolerance:.2g}", shipped)
        rows.append({"output": name, **vars(b)})
    _show(args, t, rows)
    if args.toml:
        print(tolerances.as_toml(found))
    return 0


def cmd_sweep(args: argparse.Namespace) -> int:
    from vehil import scenario, sweep
    from vehil.perturb import parse_option

    sc = scenario.load(args.scenario)
    try:
        extra = dict(parse_option(v) for v in args.vary)
    except ValueError as exc:
        raise scenario.ScenarioError(str(exc)) from None
    found = sweep.perturbations(sc, extra)
    if args.drives < 1:
        raise scenario.ScenarioError(f"-n {args.drives}: a sweep needs at least one drive")
    baseline = _baseline(args)
    with _dask_client(args) as client:
        result = sweep.run(
            sc,
            found,
            args.drives,
            args.board if client is not None else _board(args),
            matched=args.matched,
            seed=args.seed,
            out=Path(args.out) if args.out else None,
            console=console,
            client=client,
        )
    md = sweep.write(result)
    if args.json:
        args.json_out.append(result.to_json())
    else:
        console.print(sweep.distribution_table(result))
        console.print(sweep.flag_table(result))
    console.print(f"report {md}")
    title = f"sweep {sc.name}: {len(result.drives)} drives on {result.board}"
    _write_results(args, sweep.cases(result), title, baseline, [result.out / "sweep.png"])
    if result.stop_signal is not None:
        console.print(f"[yellow]{result.stopped}[/]")
        return 128 + result.stop_signal
    return 0


def _above_zero(kind: type) -> Callable[[str], Any]:
    """An argparse type: a count (int) or a time (float) above 0."""

    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            what = "a whole number" if kind is int else "a number"
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}") from None
        if not value > 0:
            raise argparse.ArgumentTypeError(f"{text}: give a number above 0")
        return value

    return parse


def _sizes(text: str) -> list[int]:
    """SIZE or SIZE,SIZE,...: payload sizes in bytes."""
    try:
        return [int(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: give payload sizes in bytes, e.g. 16 or 0,16,64"
        ) from None


def cmd_profile(args: argparse.Namespace) -> int:
    if args.functions:
        from vehil.fnprofile.command import profile_functions

        return profile_functions(args, console)
    from vehil import profile, profile_report
    from vehil.boards import make_board

    bauds = (
        profile.BAUDS_ALL if args.bauds == "all" else tuple(int(b) for b in args.bauds.split(","))
    )
    # Where the figures go, and what they are compared with: checked before measuring.
    out = Path(
        args.out or runs_dir() / f"profile-{args.board if args.board.isidentifier() else 'port'}"
    )
    out.mkdir(parents=True, exist_ok=True)
    old = _profile_json(Path(args.compare)) if args.compare else None
    # simavr paced to the wall clock, so host-clock round trips are the chip's.
    simavr = SimavrOptions(realtime=True) if args.board == "simavr" else None
    board = make_board(args.board, BoardOptions(timeout_s=args.timeout), simavr)
    figures: dict = {"board": args.board, "uart": [vars(profile.uart_setting(b)) for b in bauds]}
    console.print(profile_report.uart_table(figures["uart"]))
    misses: list[str] = []
    with board.session() as link:
        assert link.info is not None
        figures["info"] = link.info.fields
        console.print(
            f"probe overhead: {link.info.fields['probe_cycles']} cycles, "
            "measured at boot and subtracted from every step"
        )
        if not args.no_sweep and not args.budgets:
            figures["sweep"] = profile.sweep(
                link,
                bauds,
                args.count,
                progress=lambda b: console.print(f"  swept {b:,} baud", style="dim"),
            )
            console.print(profile_report.latency_table(figures["sweep"], args.board))
            console.print(profile_report.throughput_table(figures["sweep"], args.board))
            if args.board.startswith("simavr"):  # cycle-exact there
                figures["board_costs"] = profile.board_costs(link)
                console.print(profile_report.board_cost_table(figures["board_costs"], args.board))
            # At 115200 nothing but the UART limits streaming: its share is simavr's bit count.
            best = max(
                (
                    tp["line_fraction"]
                    for p in figures["sweep"]
                    if p["baud"] == 115200
                    for tp in p.get("throughput", [])
                    if "line_fraction" in tp
                ),
                default=None,
            )
            if best and args.board == "simavr":
                figures["simavr_bits_per_byte"] = 10 / best
                console.print(
                    f"simavr (paced to the wall clock) streams at most {best * 100:.1f} % of the "
                    f"10-bit line rate at 115,200 baud: {10 / best:.2f} bit times per byte (8N1 "
                    f"is 10; its source counts 11). Multiply its wire times by {best:.3f} for a "
                    "chip's."
                )
        if not args.no_estimators or args.budgets:
            names = tuple(n for n in (args.estimators or "").split(",") if n)
            figures["estimators"] = profile.estimator_costs(
                link, args.board, names=names, sizes=args.sizes
            )
            console.print(profile_report.estimator_table(figures["estimators"], args.board))
            misses = profile.budget_misses(figures["estimators"])
            for line in misses:
                console.print(f"[red]over budget: {line}[/]")
    if args.board == "qemu":
        console.print(
            "[yellow]QEMU ignores the baud rate and times with the host clock: its "
            "latencies and cycles are not chip figures.[/]"
        )
    profile.save(figures, out / "profile.json")
    if args.json:
        args.json_out.append(figures)  # the figures rather than their tables
    for png in profile_report.plots(figures, out):
        console.print(f"plot {png}")
    console.print(f"figures {out / 'profile.json'}")
    if old is not None:
        slower = profile.compare_figures(old, figures)
        for line in slower:
            console.print(f"[red]slower:[/] {line}")
        if not slower:
            console.print(f"[green]nothing slower than in {args.compare}[/]")
        return 1 if slower or (args.budgets and misses) else 0
    return 1 if args.budgets and misses else 0


def _profile_json(path: Path) -> dict[str, Any]:
    """An earlier `vehil profile`'s figures, to compare with."""
    try:
        old = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise VehilError(
            f"{path}: not a profile.json ({exc}): give one `vehil profile` wrote"
        ) from None
    if not isinstance(old, dict) or "board" not in old:
        raise VehilError(f"{path}: not a profile.json: give one `vehil profile` wrote")
    return old


def cmd_bench(args: argparse.Namespace) -> int:
    from rich.console import Console as RichConsole

    from vehil import runner, scenario

    sc = scenario.load(args.scenario)
    t = Table(title=f"host-side throughput: {sc.name} through the runner (lockstep)")
    for col in ("board", "samples", "wall s", "samples/s"):
        t.add_column(col, justify="right")
    rows = []
    for name in args.boards.split(","):
        run = runner.run(sc, name, console=RichConsole(quiet=True), timeout_s=args.timeout)
        rate = run.done / run.wall_s if run.wall_s else 0
        rows.append(
            {"board": name, "samples": run.done, "wall_s": run.wall_s, "samples_per_s": rate}
            | ({"error": run.error} if run.error else {})
        )
        t.add_row(
            name,
            f"{run.done:,}",
            f"{run.wall_s:.2f}",
            f"{rate:,.0f}" if not run.error else f"[red]{run.error}[/]",
        )
    t.caption = "native is the host's own ceiling: a board slower than it is the board or its link"
    _show(args, t, rows)
    return 0


def _file_error(exc: OSError) -> str:
    """An OSError as a user reads it: the path, what went wrong, and what to do."""
    what = exc.strerror or str(exc)
    hint = {
        errno.EEXIST: "a file is where a folder should be: name a folder",
        errno.ENOTDIR: "a file is where a folder should be: name a folder",
        errno.EACCES: "name a folder you can write",
        errno.EROFS: "name a folder you can write",
        errno.ENOSPC: "make room, or name another disk",
    }.get(exc.errno or 0)
    where = f"{exc.filename}: " if exc.filename else ""
    return f"{where}{what}" + (f" ({hint})" if hint else "")


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="vehil", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("build", help="build the firmware, the simavr bridge and the native library")
    p.add_argument("--only", action="append", choices=("firmware", "firmware-ev", "sim", "native"))
    _add_boot_baud_option(p, _BOOT_BAUD_BUILT)
    p.add_argument("--verbose", action="store_true")
    p.set_defaults(func=cmd_build)

    p = sub.add_parser(
        "new", help="write a project (vehil.toml) or an estimator that builds and passes as written"
    )
    p.add_argument("what", choices=("project", "estimator"))
    p.add_argument("name", nargs="?", help="project: its folder (default .); estimator: its name")
    p.add_argument("--title", help="estimator: a one-line title")
    p.add_argument(
        "--wrap",
        metavar="HEADER",
        help="estimator: wrap a library vendored in third_party/ (its header): manifest, "
        "wrapper with the library's type in a size-checked slot",
    )
    p.add_argument("--project-name", help="project: its name (default: the folder's)")
    p.set_defaults(func=cmd_new)

    p = sub.add_parser("info", help="connect to a board and show what it reports")
    _add_board_options(p)
    p.set_defaults(func=cmd_info)

    p = sub.add_parser(
        "flash", help="program a Mega 2560 through its bootloader (avrdude), then show INFO"
    )
    where = p.add_mutually_exclusive_group()
    where.add_argument("--port", help="a real board's serial port, e.g. /dev/ttyACM0")
    where.add_argument(
        "--board", help="simavr-bootloader, labgrid:PLACE (its network serial port), or a port"
    )
    p.add_argument(
        "--env",
        default="offline",
        choices=("offline", "megaatmega2560"),
        help="PlatformIO env to build the image with (default offline)",
    )
    p.add_argument("--image", help="flash this Intel HEX (or ELF) instead of building one")
    _add_json_option(p)
    p.add_argument(
        "--baud", type=int, default=115200, help="the bootloader's baud rate (the Mega's: 115200)"
    )
    _add_boot_baud_option(p, f"{_BOOT_BAUD_BUILT}; with --image, the rate that image boots at")
    p.add_argument(
        "--timeout", type=_above_zero(float), default=2.0, help="seconds to wait for each reply"
    )
    p.set_defaults(func=cmd_flash)

    p = sub.add_parser("ping", help="measure PING round trips")
    _add_board_options(p)
    p.add_argument("--count", type=_above_zero(int), default=1000)
    p.add_argument("--size", type=int, default=16, help="payload bytes; -1 for random sizes")
    p.add_argument(
        "--window", type=_above_zero(int), default=1, help="PINGs in flight (1: stop-and-wait)"
    )
    p.set_defaults(func=cmd_ping)

    p = sub.add_parser("demo", help="boot a board, show INFO, ping it, stream passthrough samples")
    _add_board_options(p)
    p.add_argument("--samples", type=_above_zero(int), default=5000)
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("run", help="run scenarios on boards, record them, and report")
    p.add_argument(
        "scenario",
        nargs="+",
        help="scenario .toml files, names of shipped ones, or globs ('manf-*', 'dir/*.toml')",
    )
    p.add_argument(
        "--jobs",
        type=int,
        default=1,
        help="boards run at once, one process each (several scenarios: one summary table; "
        "--out DIR gets a folder per scenario)",
    )
    _add_board_options(p)
    _add_run_options(p)
    _add_result_options(p)
    _add_dask_options(p)
    p.add_argument(
        "--window", type=_above_zero(int), default=None, help="samples in flight (lockstep)"
    )
    p.add_argument(
        "--profile", action="store_true", help="simavr: cycles per function of every step, too"
    )
    p.set_defaults(func=cmd_run_several)

    p = sub.add_parser(
        "replay", help="run a recorded drive (recording, CSV, MDF4, CAN log) on a board"
    )
    p.add_argument(
        "log", help="a run.arrow (or its folder), .csv, .mf4, or a CAN .blf, .asc, .log (candump)"
    )
    p.add_argument("--scenario", required=True, help="estimator, tolerances and column mapping")
    p.add_argument(
        "--accept-truncated",
        action="store_true",
        help="replay a recording that holds less than its whole drive (refused by default)",
    )
    _add_board_options(p)
    _add_run_options(p)
    p.set_defaults(func=cmd_replay)

    p = sub.add_parser("compare", help="compare the board outputs of two recorded runs")
    p.add_argument("run_a", help="a run's folder or its run.arrow (A)")
    p.add_argument("run_b", help="another run of the same drive (B), compared with A")
    p.add_argument("--atol", type=float, default=0.0, help="accept differences up to this")
    _add_json_option(p)
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("scenarios", help="list the shipped scenarios")
    _add_json_option(p)
    p.set_defaults(func=cmd_scenarios)

    p = sub.add_parser(
        "estimators", help="the estimators: inputs, outputs, parameters, units, Q formats"
    )
    p.add_argument("name", nargs="?", help="one estimator in full")
    _add_json_option(p)
    p.set_defaults(func=cmd_estimators)

    p = sub.add_parser("plants", help="the plants: measured and true signals, parameters")
    p.add_argument("name", nargs="?", help="one plant in full")
    _add_json_option(p)
    p.set_defaults(func=cmd_plants)

    p = sub.add_parser("reproduce", help="a paper's published figures beside ours")
    p.add_argument(
        "paper", help="the paper's key, e.g. acc, manf, stlqf (an unknown one lists them all)"
    )
    p.add_argument("--board", default=None, help="also run the board estimators on this board")
    p.set_defaults(func=cmd_reproduce)

    p = sub.add_parser(
        "tolerances", help="tolerances from an error budget: rounding × amplification × steps"
    )
    p.add_argument("scenario", help="a scenario .toml, or the name of a shipped one")
    p.add_argument("--trials", type=int, default=4, help="perturbed runs (default 4)")
    p.add_argument("--safety", type=float, default=4.0, help="tolerance = this × reach")
    p.add_argument(
        "--roundoff", type=float, default=None, help="relative rounding u (F32 2^-24, FIXED 2^-20)"
    )
    p.add_argument("--toml", action="store_true", help="print [tolerance.*] tables to paste")
    _add_json_option(p)
    p.set_defaults(func=cmd_tolerances)

    p = sub.add_parser(
        "sweep", help="Monte Carlo: a scenario over perturbed plants, error and flag distributions"
    )
    p.add_argument("scenario", help="a scenario .toml, or the name of a shipped one")
    _add_board_options(p, default="native")
    p.add_argument("-n", "--drives", type=int, default=20, help="perturbed drives (default 20)")
    p.add_argument(
        "--vary",
        action="append",
        default=[],
        metavar="NAME:rel=R",
        help="vary a plant parameter (over the scenario's [sweep]): NAME:rel=R, NAME:abs=A, "
        "NAME:lo=L,hi=H or NAME:values=A/B/C; repeatable",
    )
    p.add_argument(
        "--matched",
        action="store_true",
        help="give the estimator the drawn values of parameters it shares with the plant",
    )
    p.add_argument("--seed", type=int, default=None, help="seed of the draws (the scenario's)")
    p.add_argument("--out", default=None, help="folder for the drives, sweep.md/.png/.json")
    _add_result_options(p)
    _add_dask_options(p)
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("profile", help="baud/latency/throughput sweep and estimator costs")
    _add_board_options(p)
    p.add_argument(
        "--bauds",
        default=",".join(map(str, (115200, 250000, 500000, 1_000_000, 2_000_000))),
        help="comma-separated, or 'all' (9600 ... 2000000)",
    )
    p.add_argument(
        "--count", type=_above_zero(int), default=200, help="exchanges per point at 1 Mbaud"
    )
    p.add_argument("--no-sweep", action="store_true")
    p.add_argument("--no-estimators", action="store_true")
    p.add_argument(
        "--sizes",
        action="store_true",
        help="each estimator's flash and RAM: the image built with and without it",
    )
    p.add_argument(
        "--estimators", default="", help="comma-separated: profile only these estimators"
    )
    p.add_argument(
        "--budgets",
        action="store_true",
        help="estimators only (no sweep); exit 1 if a median misses its spec's budget",
    )
    p.add_argument("--out", default=None, help="folder for profile.json and plots")
    p.add_argument("--compare", default=None, help="an older profile.json: report what got slower")
    p.add_argument(
        "--functions",
        action="store_true",
        help="cycles per function of every step of SCENARIO (or --ping SIZE: the link's frame "
        "path), counted by the simavr bridge",
    )
    p.add_argument("scenario", nargs="?", help="with --functions: the scenario whose steps")
    p.add_argument(
        "--samples", type=_above_zero(int), default=None, help="with --functions: at most N steps"
    )
    p.add_argument(
        "--window",
        type=_above_zero(int),
        default=None,
        help="with --functions: samples (with --ping: PINGs) in flight (1: stop-and-wait)",
    )
    p.add_argument(
        "--ping",
        type=_sizes,
        default=None,
        help="with --functions: PINGs of SIZE bytes (SIZE,SIZE...: one profile each; with "
        "--per exchange, a table of each exchange's cycles by part)",
    )
    p.add_argument(
        "--per",
        choices=("step", "frame", "exchange", "run"),
        default=None,
        help="with --functions, the window: each step (a scenario's default), each frame the "
        "core handles (--ping's default), the whole firmware per PING exchange, the whole run",
    )
    p.set_defaults(func=cmd_profile)

    p = sub.add_parser("bench", help="samples/s through the runner per board (host side)")
    p.add_argument("--boards", default="native,simavr,qemu")
    p.add_argument("--scenario", default="sine")
    p.add_argument("--timeout", type=_above_zero(float), default=2.0)
    _add_json_option(p)
    p.set_defaults(func=cmd_bench)

    # Paper modules import their plants and references (scipy): only when the command
    # is not a built-in one, so `vehil info` or `vehil ping` start at once.
    words = [a for a in (sys.argv[1:] if argv is None else argv) if not a.startswith("-")]
    if not words or words[0] not in sub.choices:
        from vehil import papers

        for module in papers.papers().values():
            if hasattr(module, "add_commands"):
                module.add_commands(sub, console)
    for name, p in sub.choices.items():  # every command that prints tables: them as JSON
        with contextlib.suppress(argparse.ArgumentError):  # those that have it already
            if name != "build":  # build prints the compilers' output, no table
                _add_json_option(p)

    args = parser.parse_args(argv)
    if getattr(args, "size", None) == -1:
        args.size = None
    args.json_out = []
    as_json = getattr(args, "json", False)
    if as_json:  # stdout holds the JSON alone; tables not given as figures are kept as data
        console.stderr, console.tables = True, []
    try:
        with _signals_end_the_command():
            status = int(args.func(args))
    except VehilError as exc:
        console.print(f"[bold red]error:[/] {escape(str(exc))}")
        return 2
    except OSError as exc:  # a file or folder that could not be read or written
        console.print(f"[bold red]error:[/] {escape(_file_error(exc))}")
        return 2
    except KeyboardInterrupt as exc:
        number = getattr(exc, "signum", signal.SIGINT)
        console.print(f"[yellow]interrupted ({signal.Signals(number).name})[/]")
        return 128 + number
    finally:
        tables, console.stderr, console.tables = console.tables, False, None
    if as_json:
        found = args.json_out or tables or []
        data = found[0] if len(found) == 1 else found
        sys.stdout.write(json.dumps(data, indent=2, default=str) + "\n")
    return status


@contextlib.contextmanager
def _signals_end_the_command() -> Iterator[None]:
    """SIGTERM (a CI job's timeout) and SIGHUP (its terminal gone) stop a command as Ctrl-C
    does: a run closes its recording, writes its report and stops the board. Ctrl-C's own
    handler is set here too: a process started in the background by a shell script (`cmd &`)
    begins with SIGINT ignored, and Python then leaves it ignored, so a SIGINT sent to stop
    the run would be lost and the run would go on to its end."""

    def stop(signum: int, frame: object) -> None:
        raise Terminated(signum)

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    handlers = {
        signal.SIGINT: signal.default_int_handler,
        signal.SIGTERM: stop,
        signal.SIGHUP: stop,
    }
    before = {n: signal.signal(n, handler) for n, handler in handlers.items()}
    try:
        yield
    finally:
        for n, handler in before.items():
            signal.signal(n, handler)


if __name__ == "__main__":
    sys.exit(main())
