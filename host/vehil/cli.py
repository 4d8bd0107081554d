"""The `vehil` command line."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from rich.console import Console
from rich.table import Table

from vehil.boards import DEFAULT_BOARD, VIRTUAL_BOARDS, open_board
from vehil.errors import VehilError
from vehil.link import BoardInfo, Link
from vehil.ping import PingSummary, run_ping

console = Console()


def _add_board_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--board",
        default=DEFAULT_BOARD,
        help=f"{', '.join(VIRTUAL_BOARDS)}, or a serial port / pyserial URL "
        f"(default {DEFAULT_BOARD})",
    )
    p.add_argument(
        "--baud",
        type=int,
        default=None,
        help="switch the link to this baud rate after connecting (the firmware boots at 1000000)",
    )
    p.add_argument("--timeout", type=float, default=2.0, help="seconds to wait for each reply")


def _connect(args: argparse.Namespace):  # noqa: ANN202
    return open_board(args.board, timeout_s=args.timeout)


def _maybe_switch_baud(link: Link, baud: int | None) -> None:
    if baud is not None and baud != link.info.fields["baud"]:  # type: ignore[union-attr]
        link.set_baud(baud)


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
        f"p50 round trip = {rtt['p50'] / s.wire_limit_s:.2f} x wire limit; no loss"
    )
    return t


def cmd_build(args: argparse.Namespace) -> int:
    from vehil.build import PARTS, build

    parts = tuple(args.only) if args.only else PARTS
    for part, path in build(parts, verbose=args.verbose).items():
        console.print(f"[green]built[/] {part}: {path}")
    return 0


def cmd_info(args: argparse.Namespace) -> int:
    with _connect(args) as link:
        _maybe_switch_baud(link, args.baud)
        assert link.info is not None
        console.print(info_table(args.board, link.info))
        stats = link.stats()
        if stats["stack_size"]:
            used = stats["stack_size"] - stats["stack_unused"]
            console.print(f"stack high-water mark: {used} of {stats['stack_size']} B")
    return 0


def cmd_ping(args: argparse.Namespace) -> int:
    with _connect(args) as link:
        _maybe_switch_baud(link, args.baud)
        summary = run_ping(link, count=args.count, size=args.size, window=args.window)
        console.print(ping_table(args.board, summary))
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    """What vehil does, in one run: a board boots, answers, and streams samples."""
    import struct

    import numpy as np

    with _connect(args) as link:
        assert link.info is not None
        console.print(info_table(args.board, link.info))
        console.print(ping_table(args.board, run_ping(link, count=1000, size=16)))
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


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="vehil", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("build", help="build the firmware, the simavr bridge and the native library")
    p.add_argument("--only", action="append", choices=("firmware", "sim", "native"))
    p.add_argument("--verbose", action="store_true")
    p.set_defaults(func=cmd_build)

    p = sub.add_parser("info", help="connect to a board and show what it reports")
    _add_board_options(p)
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("ping", help="measure PING round trips")
    _add_board_options(p)
    p.add_argument("--count", type=int, default=1000)
    p.add_argument("--size", type=int, default=16, help="payload bytes; -1 for random sizes")
    p.add_argument("--window", type=int, default=1, help="PINGs in flight (1: stop-and-wait)")
    p.set_defaults(func=cmd_ping)

    p = sub.add_parser("demo", help="boot a board, show INFO, ping it, stream passthrough samples")
    _add_board_options(p)
    p.add_argument("--samples", type=int, default=5000)
    p.set_defaults(func=cmd_demo)

    args = parser.parse_args(argv)
    if getattr(args, "size", None) == -1:
        args.size = None
    try:
        return int(args.func(args))
    except VehilError as exc:
        console.print(f"[bold red]error:[/] {exc}")
        return 2
    except KeyboardInterrupt:
        console.print("[yellow]interrupted[/]")
        return 130


if __name__ == "__main__":
    sys.exit(main())
