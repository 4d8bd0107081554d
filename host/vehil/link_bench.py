"""The link's figures on simavr, printed: what the board costs per exchange, how much of
the line rate it streams, how soon it answers, and how close stop-and-wait round trips
come to the wire and the board's compute.

    python -m vehil.link_bench            # everything (~3 min on a quiet machine)
    python -m vehil.link_bench --only round_trips,loop   # the wall-clock parts alone
    python -m vehil.link_bench --json

Cycle figures are simavr's, exact whatever the host's load. Windowed streaming, round
trips and the 100 Hz loop run on `simavr-realtime`, which is held to the chip's time only
while the host keeps up with it: the bench measures how fast simavr runs free, and
prints the host's load average with each wall-clock figure. It runs those parts ahead of
the host's other work where the host allows it (real-time round-robin scheduling, else
niceness -10), as a dedicated HIL host would; simavr-realtime then runs one real-time
priority above it (sim/README.md). For each stretch of late samples in the loop it prints
where the first one's time went, from the bridge's timing log (vehil.timing_log): sent
late by the host, answered late by the board, or read late; and the CPU time the
hypervisor gave to others meanwhile (steal).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import os
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console

from vehil import profile, runner, scenario
from vehil.boards import BoardOptions, SimavrOptions, make_board, open_board
from vehil.link import Link
from vehil.ping import run_ping
from vehil.protocol import frame as framing
from vehil.protocol.schema import SCHEMA
from vehil.timing_log import LateStretch, TimingLog
from vehil.vcd import frames, uart_bytes

F_CPU = 16_000_000
PING_SIZE = 16
STREAM_WINDOW = 8
STREAM_BAUDS = (1_000_000, 2_000_000)
ROUND_TRIP_BAUDS = (115200, 1_000_000)
ROUND_TRIP_LIMIT = 1.15  # p99 against wire + board compute: the target
# Steps in lockstep, the frames behind each arriving while it runs, against stop-and-wait.
STEP_SCENARIOS = ("braking/manf-hard-stop-fixed", "stlqf/heavy-rolling-fixed")
STEP_SAMPLES = 1000
# A 100 Hz stop-and-wait loop through the 1 Mbaud link, in real time: no sample late.
LOOP_SCENARIO = "stlqf/heavy-rolling-fixed"  # STLQF FIXED, 60 s at 100 Hz
# A late stretch during which a CPU was given to others this long (steal) is the host's.
STOLEN_MS = 10
LATE_STRETCHES_SHOWN = 12


def _set_baud(link: Link, baud: int) -> None:
    if link.info is None or int(link.info.fields["baud"]) != baud:
        link.set_baud(baud)


def streaming(count: int, bridge: SimavrOptions) -> list[dict[str, Any]]:
    """Windowed 16-byte PINGs on simavr-realtime: the board's share of the 10-bit line rate,
    by its own clock. simavr running free does a 2 Mbaud exchange in ~60 us of host time,
    which a Python host cannot keep up with: the board waited for requests there, and the
    figure measured the host (33-49 % at 2 Mbaud from run to run). Held to the wall clock,
    the host keeps the window full and the figure is the board's, as long as the host is
    not late, which lowers it and never raises it."""
    rows = []
    board = make_board("simavr-realtime", BoardOptions(timeout_s=2.0), bridge)
    with board.session() as link:
        for baud in STREAM_BAUDS:
            load = _load()
            _set_baud(link, baud)
            point = profile.throughput_point(link, STREAM_WINDOW, count, PING_SIZE)
            rows.append({"baud": baud, **point, "load_before": load, "load_after": _load()})
    return rows


# The PONG carries the board's 32-bit cycle count. Through its first 2**24 cycles (1.05 s)
# the count's top byte is 0, which ends the reply's first COBS block early, so the reply's
# first byte goes out ~800 cycles sooner than on a board that has run longer: than in
# every round trip below, which come after the baud switches and the 115200 part.
SETTLED_CYCLES = 1 << 24


def reply_latency(count: int, bridge: SimavrOptions) -> dict[str, dict[str, float]]:
    """Board cycles from reading a 16-byte PING's delimiter out of UDR0 to writing its PONG's
    first byte into UDR0 (stop-and-wait, 1 Mbaud), from the bridge's VCD trace: the
    request's last byte to its reply queued, plus the few cycles the TX interrupt takes
    to start it. `count` exchanges in the board's first 2**24 cycles and as many after."""
    with tempfile.TemporaryDirectory() as tmp:
        vcd = Path(tmp) / "uart.vcd"
        with open_board("simavr", BoardOptions(), dataclasses.replace(bridge, vcd=vcd)) as link:
            run_ping(link, count=count, size=PING_SIZE, window=1)
            while link.request("PING", payload=b"").fields()["timestamp"] < SETTLED_CYCLES:
                time.sleep(0.05)  # simavr runs free meanwhile
            run_ping(link, count=count, size=PING_SIZE, window=1)
        sent, received = uart_bytes(vcd)
    request_wire = len(framing.encode(0, 1, bytes(PING_SIZE)))
    ends = [f[-1].t_ns for f in frames(received) if len(f) == request_wire]
    starts = sorted(f[0].t_ns for f in frames(sent))
    early: list[float] = []
    settled: list[float] = []
    for end in ends:
        first = next((s for s in starts if s > end), None)
        if first is not None:
            cycles = (first - end) * F_CPU / 1e9
            (early if end * F_CPU / 1e9 < SETTLED_CYCLES else settled).append(cycles)
    return {"first_2e24_cycles": _summary(early), "settled": _summary(settled)}


def _summary(cycles: list[float]) -> dict[str, float]:
    return {
        "exchanges": len(cycles),
        "median": statistics.median(cycles),
        "min": min(cycles),
        "max": max(cycles),
    }


def simavr_speed(bridge: SimavrOptions, seconds: float = 3.0) -> float:
    """Simulated time per wall-clock second of simavr running free, the board busy all
    along (bursts of PINGs at 2 Mbaud): below 1, this host cannot hold it to real time."""
    with open_board("simavr", BoardOptions(), bridge) as link:
        link.set_baud(2_000_000)
        start, board, n = time.perf_counter(), 0.0, 0
        while time.perf_counter() - start < seconds:
            s = run_ping(link, count=200, size=64, window=profile.WINDOWS[-1])
            board += float(s.board_interval_s.sum())
            n += 1
        return board / (time.perf_counter() - start)


def round_trips(count: int, latency_cycles: float, bridge: SimavrOptions) -> list[dict[str, Any]]:
    """Stop-and-wait 16-byte PINGs on simavr-realtime against wire time + board compute
    (`latency_cycles`: a board's past its first 2**24 cycles, as this one is once at each
    baud rate's measured exchanges)."""
    rows = []
    load = _load()
    board = make_board("simavr-realtime", BoardOptions(timeout_s=2.0), bridge)
    with board.session() as link:
        for baud in ROUND_TRIP_BAUDS:
            _set_baud(link, baud)
            run_ping(link, count=50, size=PING_SIZE, window=1)  # settle
            s = run_ping(link, count=count, size=PING_SIZE, window=1)
            wire_s = s.wire_bytes * profile.SIMAVR_BITS_PER_BYTE[bridge.uart] / baud
            # The request's receive interrupts and fetch run as its bytes arrive; what
            # the wire does not cover is the last byte to the reply queued.
            bound_s = wire_s + latency_cycles / F_CPU
            p99 = float(np.percentile(s.rtt_s, 99))
            rows.append(
                {
                    "baud": baud,
                    "p50_ms": float(np.percentile(s.rtt_s, 50)) * 1e3,
                    "p99_ms": p99 * 1e3,
                    "wire_plus_compute_ms": bound_s * 1e3,
                    "p99_over_bound": p99 / bound_s,
                    "load_before": load,
                    "load_after": _load(),
                }
            )
            load = rows[-1]["load_after"]
    return rows


RT_PRIORITY = 10  # SCHED_RR priority of the wall-clock parts, where the host allows it
PRIORITY_NICE = -10  # else their niceness, where the host allows that


def _raise_priority() -> str:
    """Puts this process ahead of the host's other work where permitted (root, or
    CAP_SYS_NICE): real-time round-robin scheduling, else a lower niceness. The boards
    it starts afterwards inherit it, so a round trip's wake-ups (host, simavr's reader
    and sim threads) do not wait behind the host's other work, as on a dedicated HIL
    host. Returns what is in effect."""
    try:
        os.sched_setscheduler(0, os.SCHED_RR, os.sched_param(RT_PRIORITY))
        return f"SCHED_RR {RT_PRIORITY}"
    except (PermissionError, AttributeError):
        pass
    with contextlib.suppress(PermissionError):
        if os.getpriority(os.PRIO_PROCESS, 0) > PRIORITY_NICE:
            os.setpriority(os.PRIO_PROCESS, 0, PRIORITY_NICE)
    return f"niceness {os.getpriority(os.PRIO_PROCESS, 0)}"


def _load() -> float:
    """The host's 1-minute load average (2 cores here): the context of a wall-clock figure."""
    return os.getloadavg()[0]


def realtime_loop(bridge: SimavrOptions) -> dict[str, Any]:
    """STLQF FIXED stop-and-wait at 100 Hz in real time through the 1 Mbaud link on
    simavr-realtime, the whole 60 s drive: late samples (a RESULT back after the next
    sample was due), round trips and the step's cycles."""
    sc = scenario.load(LOOP_SCENARIO)
    load = _load()
    with tempfile.TemporaryDirectory() as tmp:
        log_path = Path(tmp) / "timing.log"
        board = make_board(
            "simavr-realtime", BoardOptions(), dataclasses.replace(bridge, timing=log_path)
        )
        r = runner.run(sc, board, realtime=True, console=Console(quiet=True))
        log = TimingLog.read(log_path)
    rtt = r.rtt_s * 1e3 if r.done else np.zeros(1)
    stretches = None
    if r.done:
        sample = SCHEMA.messages["SAMPLE"]
        inputs = sc.estimator.encode_inputs(np.zeros(len(sc.estimator.inputs)), sc.mode)
        request = len(framing.encode(sample.type, 1, sample.pack(index=0, inputs=inputs)))
        stretches = log.late_stretches(request, r.late, r.rtt_s, sc.sample_time)
    stolen = [s for s in stretches or [] if max(s.steal_ms, default=0) >= STOLEN_MS]
    return {
        "scenario": LOOP_SCENARIO,
        "baud": int(r.info.get("baud", 0)),
        "ended": r.ended,
        "error": r.error,
        "samples": r.done,
        "expected": r.expected,
        "late": int(np.count_nonzero(r.late)) if r.done else None,
        "rtt_p50_ms": float(np.percentile(rtt, 50)),
        "rtt_p99_ms": float(np.percentile(rtt, 99)),
        "rtt_max_ms": float(np.max(rtt)),
        "step_max_cycles": int(np.max(r.cycles)) if r.done else None,
        "late_stretches": [dataclasses.asdict(s) for s in stretches]
        if stretches is not None
        else None,
        "late_with_steal": sum(s.samples for s in stolen),
        "steal_ms": [int(x) for x in log.steal[:, 1:].sum(axis=0)] if len(log.steal) else [],
        "sample_time_ms": sc.sample_time * 1e3,
        "load_before": load,
        "load_after": _load(),
    }


def step_cycles() -> list[dict[str, Any]]:
    """Median cycles per step (RESULT's, the probe subtracted) stop-and-wait and in
    lockstep: in lockstep the receive interrupts of the frames queued behind a step
    land in it and count in its cycles."""
    rows = []
    quiet = Console(quiet=True)
    for name in STEP_SCENARIOS:
        sc = scenario.load(name)
        sc = dataclasses.replace(sc, duration=STEP_SAMPLES * sc.sample_time)
        medians = {}
        for label, window in (("stop_and_wait", 1), ("lockstep", None)):
            r = runner.run(sc, "simavr", window=window, console=quiet)
            medians[label] = float(np.median(r.cycles))
        ratio = medians["lockstep"] / medians["stop_and_wait"]
        rows.append({"scenario": name, **medians, "lockstep_over_stop_and_wait": ratio})
    return rows


PARTS = (
    "board_costs",
    "streaming",
    "reply_latency",
    "simavr_speed",
    "round_trips",
    "steps",
    "loop",
)


def run(count: int, parts: tuple[str, ...] = PARTS, uart: str = "chip") -> dict[str, Any]:
    """The figures of `parts`, on simavr boards whose UART0 is timed by `uart`: "chip" (the
    ATmega2560's) or "simavr" (simavr 1.6's own, to compare: sim/README.md)."""
    bridge = SimavrOptions(uart=uart)
    figures: dict[str, Any] = {"uart": uart}
    if "board_costs" in parts:
        with open_board("simavr", BoardOptions(), bridge) as link:
            figures["board_costs"] = profile.board_costs(
                link, bits=profile.SIMAVR_BITS_PER_BYTE[uart]
            )
    if "reply_latency" in parts or "round_trips" in parts:
        # The round trips' bound needs the board's compute.
        figures["reply_latency_cycles"] = reply_latency(min(count, 300), bridge)
    if "simavr_speed" in parts:
        figures["simavr_speed"] = simavr_speed(bridge)
    if "streaming" in parts or "round_trips" in parts or "loop" in parts:
        figures["priority"] = _raise_priority()
    if "streaming" in parts:
        figures["streaming"] = streaming(count, bridge)
    if "round_trips" in parts:
        latency = figures["reply_latency_cycles"]["settled"]["median"]
        figures["round_trips"] = round_trips(count, latency, bridge)
    if "steps" in parts:
        figures["step_cycles"] = step_cycles()
    if "loop" in parts:
        figures["realtime_loop"] = realtime_loop(bridge)
    return figures


def report(f: dict[str, Any]) -> str:
    lines = []
    if "board_costs" in f:
        lines.append(
            "cycles per streamed PING exchange (bursts sent at once, their bytes arriving "
            "at the line rate; by the board's clock; with the wire: no less than the reply's "
            f"time on the wire's {profile.SIMAVR_BITS_PER_BYTE[f['uart']]}-bit bytes):"
        )
    for c in f.get("board_costs", []):
        lines.append(
            f"  {c['baud']:>9,} baud, {c['size']:3d} B: board {c['board_cycles']:7,.0f} cycles "
            f"({c['arrived_cycles']:,.0f} with the requests already in), with the wire "
            f"{c['cycles']:,.0f}: {c['line_share'] * 100:.1f} % of the 10-bit line rate"
        )
    if "streaming" in f:
        lines.append(
            f"windowed streaming, {PING_SIZE}-byte PINGs, window {STREAM_WINDOW}, on "
            "simavr-realtime, by the board's clock (lower when the host falls behind):"
        )
    for s in f.get("streaming", []):
        lines.append(
            f"  {s['baud']:>9,} baud: {s['board_frames_s']:,.0f} exchanges/s, "
            f"{s['board_line_fraction'] * 100:.1f} % of the 10-bit line rate "
            f"(overruns {s['overruns']}, CRC errors {s['crc_errors']}; host load "
            f"{s['load_before']:.2f} before, {s['load_after']:.2f} after)"
        )
    if "reply_latency_cycles" in f:
        r, e = f["reply_latency_cycles"]["settled"], f["reply_latency_cycles"]["first_2e24_cycles"]
        lines.append(
            f"request's last byte to its reply's first byte in UDR0 ({PING_SIZE}-byte PING, "
            f"{r['exchanges']} exchanges, the board past its first 2**24 cycles as in every "
            f"round trip below): median {r['median']:,.0f}, min {r['min']:,.0f}, "
            f"max {r['max']:,.0f} cycles; in its first 2**24 cycles (1.05 s; the PONG's "
            f"timestamp's top byte 0) median {e['median']:,.0f}, max {e['max']:,.0f}"
        )
    if "simavr_speed" in f:
        lines.append(
            f"simavr running free, board busy: {f['simavr_speed']:.2f} s of chip time per wall "
            "second"
            + (
                " (below 1: this host cannot hold simavr-realtime to real time)"
                if f["simavr_speed"] < 1
                else ""
            )
        )
    if "priority" in f:
        lines.append(f"wall-clock parts at {f['priority']} (host load beside each figure)")
    if "round_trips" in f:
        lines.append(
            f"stop-and-wait {PING_SIZE}-byte PINGs on simavr-realtime over a Unix-domain socket "
            f"(host clock; wire at {profile.SIMAVR_BITS_PER_BYTE[f['uart']]} bits a byte):"
        )
    for t in f.get("round_trips", []):
        lines.append(
            f"  {t['baud']:>9,} baud: p50 {t['p50_ms']:.3f} ms, p99 {t['p99_ms']:.3f} ms, wire + "
            f"compute {t['wire_plus_compute_ms']:.3f} ms: p99 {t['p99_over_bound']:.2f} x "
            f"(target <= {ROUND_TRIP_LIMIT}; host load {t['load_before']:.2f} before, "
            f"{t['load_after']:.2f} after)"
        )
    if "step_cycles" in f:
        lines.append(
            "cycles per estimator step, median, stop-and-wait and lockstep (target: within 5 %):"
        )
    for c in f.get("step_cycles", []):
        lines.append(
            f"  {c['scenario']}: {c['stop_and_wait']:,.0f} / {c['lockstep']:,.0f} cycles, "
            f"lockstep {(c['lockstep_over_stop_and_wait'] - 1) * 100:+.1f} %"
        )
    if "realtime_loop" in f:
        q = f["realtime_loop"]
        verdict = "held" if q["ended"] == "completed" and q["late"] == 0 else "NOT held"
        lines.append(
            f"{q['scenario']} stop-and-wait at {1e3 / q['sample_time_ms']:.0f} Hz in real time on "
            f"simavr-realtime over a Unix-domain socket, {q['baud']:,} baud: {verdict}: "
            f"{q['samples']:,} of {q['expected']:,} samples ({q['ended']}), {q['late']} late; "
            f"round trip p50 {q['rtt_p50_ms']:.2f} ms, p99 {q['rtt_p99_ms']:.2f} ms, "
            f"max {q['rtt_max_ms']:.2f} ms; "
            f"step max {q['step_max_cycles']:,} cycles (host load {q['load_before']:.2f} before, "
            f"{q['load_after']:.2f} after)" + (f"; {q['error']}" if q["error"] else "")
        )
        if q["steal_ms"]:
            lines.append(
                "  the hypervisor gave this machine's CPUs to others for "
                + "/".join(str(x) for x in q["steal_ms"])
                + f" ms (steal, CPU {'/'.join(str(i) for i in range(len(q['steal_ms'])))}) "
                f"during the run; {q['late_with_steal']} of the late samples came in stretches "
                f"with {STOLEN_MS} ms of it or more"
            )
        if q["late"] and q["late_stretches"] is None:
            lines.append("  (the bridge's timing log did not hold one request a sample)")
        stretches = q["late_stretches"] or []
        for s in stretches[:LATE_STRETCHES_SHOWN]:
            lines.append(
                "  late " + LateStretch(**{**s, "steal_ms": tuple(s["steal_ms"])}).describe()
            )
        if len(stretches) > LATE_STRETCHES_SHOWN:
            lines.append(f"  ... {len(stretches) - LATE_STRETCHES_SHOWN} more stretches (--json)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m vehil.link_bench", description=__doc__)
    ap.add_argument("--count", type=int, default=2000, help="exchanges per streaming point")
    ap.add_argument("--json", action="store_true", help="the figures as JSON")
    ap.add_argument(
        "--only",
        default=",".join(PARTS),
        help=f"comma-separated parts to run (default: all of {','.join(PARTS)})",
    )
    ap.add_argument(
        "--uart",
        choices=tuple(profile.SIMAVR_BITS_PER_BYTE),
        default="chip",
        help="UART0's timing on the simavr boards: the ATmega2560's, or simavr's own",
    )
    args = ap.parse_args(argv)
    parts = tuple(p.strip() for p in args.only.split(",") if p.strip())
    unknown = [p for p in parts if p not in PARTS]
    if unknown:
        ap.error(f"unknown part(s) {', '.join(unknown)}: choose from {', '.join(PARTS)}")
    figures = run(args.count, parts, args.uart)
    print(json.dumps(figures, indent=1) if args.json else report(figures))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
