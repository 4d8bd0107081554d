"""Where the time of an exchange goes: baud sweeps, windowed throughput, estimator cost.

Figures are labelled by what they measure:
- chip: cycles counted by the board (simavr is cycle-exact; a real Mega is the chip);
- wire: bytes x 10 / baud, the UART's floor at 8N1;
- host clock: round trips as the host sees them, which include the board process
  (simavr, QEMU) or the USB bridge of a real board.
The simavr bridge times its UART as the chip does (10 bits an 8N1 byte; simavr's own
timing, 11, with its --uart simavr: sim/README.md); the sweep measures the wire's
ratio to the line rate and states it. QEMU ignores the baud rate altogether. A real
Mega adds its 16U2 bridge: up to 4.1 ms per reply.
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vehil import estimators, scenario
from vehil.errors import VehilError
from vehil.link import Link
from vehil.ping import run_ping
from vehil.protocol import frame as framing

BAUDS_ALL = (9600, 19200, 38400, 57600, 115200, 250000, 500000, 1_000_000, 2_000_000)
BAUDS_DEFAULT = (115200, 250000, 500000, 1_000_000, 2_000_000)
SIZES = (0, 16, 64, 112)
WINDOWS = (1, 2, 4, 8, 16, 32)
F_CPU = 16_000_000
USB_BRIDGE_S = 4.096e-3  # the 16U2 flushes board->host every 4.096 ms
# Bits an 8N1 byte takes on the simavr bridge's wire, by its --uart timing: the chip's, or
# simavr's own, which counts a parity bit (sim/README.md)
SIMAVR_BITS_PER_BYTE = {"chip": 10, "simavr": 11}


@dataclass(frozen=True)
class UartSetting:
    baud: int
    ubrr: int
    actual: float
    error_pct: float


def uart_setting(baud: int, f_cpu: int = F_CPU) -> UartSetting:
    """UBRR with U2X (8 samples per bit), as the firmware sets it."""
    ubrr = max(0, round(f_cpu / (8 * baud)) - 1)
    actual = f_cpu / (8 * (ubrr + 1))
    return UartSetting(baud, ubrr, actual, (actual / baud - 1) * 100)


def _pct(x: np.ndarray) -> dict[str, float]:
    return {f"p{q}": float(np.percentile(x, q)) for q in (50, 95, 99)} | {"max": float(x.max())}


def _stats_delta(before: dict[str, Any], after: dict[str, Any]) -> dict[str, Any]:
    delta: dict[str, Any] = {
        k: int(after[k] - before[k]) for k in ("crc_errors", "cobs_errors", "overruns")
    }
    # Board cycles per frame from decode to reply queued (the STATS request itself included).
    frames = after["rx_frames"] - before["rx_frames"]
    delta["frame_cycles"] = (after["frame_cycles"] - before["frame_cycles"]) / max(1, frames)
    return delta


def latency_point(link: Link, size: int, count: int) -> dict[str, Any]:
    before = link.stats()
    try:
        s = run_ping(link, count=count, size=size, window=1)
    except VehilError as exc:
        return {"size": size, "error": str(exc)}
    wire_s = s.wire_limit_s
    rtt = _pct(s.rtt_s * 1e3)
    return {
        "size": size,
        "wire_bytes": s.wire_bytes,
        "wire_ms": wire_s * 1e3,
        "rtt_ms": rtt,
        "board_interval_ms": _pct(s.board_interval_s * 1e3) if len(s.board_interval_s) else None,
        "p99_over_wire": rtt["p99"] / (wire_s * 1e3),
        **_stats_delta(before, link.stats()),
        "lost": 0,
    }


def throughput_point(link: Link, window: int, count: int, size: int = 16) -> dict[str, Any]:
    before = link.stats()
    start = time.perf_counter()
    try:
        s = run_ping(link, count=count, size=size, window=window)
    except VehilError as exc:
        return {"window": window, "error": str(exc)}
    elapsed = time.perf_counter() - start
    baud = s.baud
    per_direction = s.wire_bytes / 2 + 2  # the PONG's 4-byte stamp makes replies the longer
    frames_s = count / elapsed
    # The board's clock between the first and last PONG: chip time, whatever the host did.
    board_span = float(s.board_interval_s.sum())
    board_frames_s = (count - 1) / board_span if board_span > 0 else float("nan")
    return {
        "window": window,
        "frames_s": frames_s,
        "payload_bytes_s": frames_s * size,
        "line_fraction": frames_s * per_direction * 10 / baud,
        "board_frames_s": board_frames_s,
        "board_line_fraction": board_frames_s * per_direction * 10 / baud,
        # Its spread: the span above takes in every pause of the host's (a loaded host's
        # stall leaves the board idle with the window empty); the median interval does not.
        "board_interval_ms": _pct(s.board_interval_s * 1e3) if len(s.board_interval_s) else None,
        **_stats_delta(before, link.stats()),
    }


BURST_BAUDS = (1_000_000, 2_000_000)
BURSTS = 12
BURST_SIZES = (0, 16, 32, 64)  # at least three requests fit the board's RX buffer


def board_cost_point(link: Link, size: int, bursts: int = BURSTS, bits: int = 10) -> dict[str, Any]:
    """Board cycles per exchange of a `size`-byte PING streamed at the link's baud, by the
    board's own clock, whatever the host's pace.

    Bursts of as many PINGs as the board's RX buffer holds, in one write (Link.corked: a
    burst packed request by request reached simavr in pieces, by the host's pace, and the
    figure moved by 25 % from run to run): their bytes come in back to back at the line
    rate, as when the host keeps the window full. The PONG timestamps' span over the
    burst, divided by the exchanges it holds, is the board's cost of an exchange:
    receiving, decoding and checking the request, handling it, encoding and sending the
    reply. (Not the median spacing: the board takes in the later requests during the
    first exchanges, so those are slow and the rest fast; neither is a stream's.) A
    stream goes no faster than its replies leave: the exchange takes the board's cost or
    the reply's time on the wire (`bits` a byte), whichever is longer, and its share of
    the 10-bit line rate follows from that (simavr's own 11-bit bytes cap it at 10/11).
    The second half's spacing, every request in the RX buffer, is the board's cost
    without the receiving. Cycle-exact on simavr.
    """
    assert link.info is not None
    baud = int(link.info.fields["baud"])
    request = len(framing.encode(0, 1, bytes(size)))
    reply = len(framing.encode(0, 1, bytes(size + 4)))
    # no more than the link keeps in flight: a burst sent in two goes would wait for replies
    n = min(link.info.rx_buffer // request, link.max_frames)
    if n < 3:
        raise ValueError(f"{size}-byte PINGs: fewer than three fit the board's RX buffer")
    before = link.stats()
    spacings: list[int] = []
    arrived: list[int] = []
    for b in range(bursts):
        payloads = [bytes([1 + (b + i) % 255]) * size for i in range(n)]
        with link.corked():  # the whole burst in one write, whatever the host's pace
            stamps = [
                r.fields()["timestamp"]
                for r in link.pipeline((("PING", {"payload": p}) for p in payloads), window=n)
            ]
        spacing = [(y - x) & 0xFFFFFFFF for x, y in zip(stamps, stamps[1:], strict=False)]
        spacings += spacing
        arrived += spacing[n // 2 :]
    after = link.stats()
    handling = (after["frame_cycles"] - before["frame_cycles"]) / max(
        1, after["rx_frames"] - before["rx_frames"]
    )
    board = float(np.mean(spacings))
    per_exchange = max(board, max(request, reply) * bits * F_CPU / baud)
    wire_cycles = max(request, reply) * 10 * F_CPU / baud  # the 10-bit line rate
    return {
        "baud": baud,
        "size": size,
        "request_bytes": request,
        "reply_bytes": reply,
        "board_cycles": board,
        "cycles": per_exchange,
        "arrived_cycles": float(np.median(arrived)),
        "handling_cycles": handling,
        "line_share": min(1.0, wire_cycles / per_exchange),
        "overruns": after["overruns"] - before["overruns"],
    }


def board_costs(
    link: Link,
    sizes: tuple[int, ...] = BURST_SIZES,
    bauds: tuple[int, ...] = BURST_BAUDS,
    bits: int = 10,
) -> list[dict[str, Any]]:
    try:
        rows = []
        for baud in bauds:
            link.set_baud(baud)
            rows += [board_cost_point(link, size, bits=bits) for size in sizes]
        return rows
    finally:
        link.set_baud(1_000_000)


def sweep(
    link: Link,
    bauds: tuple[int, ...],
    count: int,
    sizes: tuple[int, ...] = SIZES,
    windows: tuple[int, ...] = WINDOWS,
    progress: Any = None,
) -> list[dict[str, Any]]:
    points = []
    for baud in bauds:
        setting = uart_setting(baud)
        entry: dict[str, Any] = {"baud": baud, **vars(setting)}
        try:
            link.set_baud(baud)
        except VehilError as exc:
            entry["error"] = str(exc)
            points.append(entry)
            continue
        # Fewer exchanges at slow rates: each costs tens of milliseconds there.
        n = max(20, min(count, int(count * baud / 1_000_000)))
        entry["latency"] = [latency_point(link, size, n) for size in sizes]
        entry["throughput"] = [throughput_point(link, w, n * 2) for w in windows]
        points.append(entry)
        if progress:
            progress(baud)
    link.set_baud(1_000_000)
    return points


def _scenario_for(name: str, mode: str) -> scenario.Scenario | None:
    """The estimator's budget scenario (else its first shipped one), run in `mode`."""
    import dataclasses

    chosen = estimators.get(name).budget_scenario
    paths = [chosen] if chosen else scenario.shipped()
    for path in paths:
        try:
            sc = scenario.load(path)
        except VehilError:
            if chosen:
                raise
            continue
        if sc.estimator.name == name:
            return sc if sc.mode == mode else dataclasses.replace(sc, mode=mode)
    return None


def footprint(name: str) -> dict[str, int]:
    """Flash and static RAM the estimator adds to the image: the default image's set (or
    all, for one the default leaves out) built with and without it, the difference of the
    two ELFs. Helpers and tables it alone uses count; what it shares with others, and the
    state area up to the largest other state, do not. In a project, its image's set with
    its C (vehil.toml), with and without the estimator."""
    from vehil import project
    from vehil.build import project_image, registry
    from vehil.build.budget import budget
    from vehil.build.platformio import build_image, default_estimators

    here = project.current()
    c_sources = here.c_sources if here else ()
    chosen = project_image(here) if here else default_estimators()
    base = chosen if name in registry.select(chosen, c_sources) else "all"
    words = base.split()
    if not words or words[0] == "all":
        others = f"{base} -{name}"
    else:
        others = " ".join(w for w in words if w != name)
    with_it, without = budget(build_image(base, c_sources)), budget(build_image(others, c_sources))
    return {
        "flash": with_it.flash - without.flash,
        "ram": with_it.static_ram - without.static_ram,
    }


def frame_bytes(spec: estimators.EstimatorSpec) -> tuple[int, int]:
    """Bytes on the wire of one SAMPLE and its RESULT."""
    # A body under 254 bytes: header, CRC, one COBS code byte and the delimiter around it.
    framing_bytes = framing.HEADER_SIZE + framing.CRC_SIZE + 2
    request = 4 * len(spec.inputs) + 2 + framing_bytes  # + the sample index u16
    reply = 4 * len(spec.outputs) + 5 + framing_bytes  # + status u8 and cycles u32
    return request, reply


def stop_and_wait_s(spec: estimators.EstimatorSpec, baud: int, compute_s: float) -> float:
    """One sample sent, computed and answered, at 10 bits per byte."""
    request, reply = frame_bytes(spec)
    return (request + reply) * 10 / baud + compute_s


def estimator_costs(
    link: Link,
    board: str,
    max_samples: int = 2000,
    names: Sequence[str] = (),
    sizes: bool = False,
) -> list[dict[str, Any]]:
    """Cycles per step of every estimator the board has (or of `names`), in each mode, over
    a scenario, stop-and-wait: no receive interrupt lands in a step, as in a real-time task.
    Each row has the spec's budget for its mode and whether the median keeps it, and with
    `sizes` the flash and RAM the estimator adds to the image (footprint)."""
    from vehil import runner

    assert link.info is not None
    on_board = {e.name: e for e in link.info.estimators}
    unknown = sorted(set(names) - set(on_board))
    if unknown:
        raise VehilError(
            f"the board has no estimator {', '.join(unknown)}; it has {', '.join(sorted(on_board))}"
        )
    rows = []
    for name, spec in sorted(estimators.estimators().items()):
        if name not in on_board or (names and name not in names):
            continue
        for mode in spec.modes:
            sc = _scenario_for(name, mode)
            row: dict[str, Any] = {"estimator": name, "mode": mode}
            if sc is None:
                row["error"] = "no shipped scenario uses it"
                rows.append(row)
                continue
            import dataclasses

            from rich.console import Console

            sc = dataclasses.replace(sc, duration=min(sc.duration, max_samples * sc.sample_time))
            run = runner.run(sc, board, window=1, console=Console(quiet=True))
            if run.error:
                row["error"] = run.error
                rows.append(row)
                continue
            fig = run.figures
            request, reply = frame_bytes(spec)
            compute_s = (fig.cycles["max"] or 0) / F_CPU
            rates = {}
            for baud in BAUDS_DEFAULT:
                exchange = stop_and_wait_s(spec, baud, compute_s)
                rates[str(baud)] = {
                    "stop_and_wait_hz": 1 / exchange,
                    "pipelined_hz": 1 / max(max(request, reply) * 10 / baud, compute_s),
                    "real_board_hz": 1 / (exchange + USB_BRIDGE_S),
                }
            row.update(
                scenario=sc.name,
                samples=run.done,
                cycles=fig.cycles,
                step_us_max=compute_s * 1e6,
                paper_hz=1 / sc.sample_time,
                request_bytes=request,
                reply_bytes=reply,
                rates=rates,
                budget=spec.budget.get(mode),
                within_budget=None
                if mode not in spec.budget
                else (fig.cycles["median"] or 0) <= spec.budget[mode],
                **({f"image_{k}": v for k, v in footprint(name).items()} if sizes else {}),
            )
            rows.append(row)
    return rows


def budget_misses(rows: list[dict[str, Any]]) -> list[str]:
    """The rows whose median misses their budget, or that could not be measured."""
    return [
        f"{r['estimator']} {r['mode']}: "
        + (r["error"] if "error" in r else f"median {r['cycles']['median']:,.0f} > {r['budget']:,}")
        for r in rows
        if r.get("within_budget") is False or ("error" in r and r.get("budget"))
    ]


def compare_figures(old: dict[str, Any], new: dict[str, Any], slack: float = 0.10) -> list[str]:
    """What got slower than `slack` (relative) from old to new, one line each."""
    lines = []
    old_lat = {
        (p["baud"], lp["size"]): lp
        for p in old.get("sweep", [])
        for lp in p.get("latency", [])
        if "rtt_ms" in lp
    }
    for p in new.get("sweep", []):
        for lp in p.get("latency", []):
            before = old_lat.get((p["baud"], lp["size"]))
            if before and "rtt_ms" in lp:
                a, b = before["rtt_ms"]["p50"], lp["rtt_ms"]["p50"]
                if b > a * (1 + slack):
                    lines.append(
                        f"round trip p50 at {p['baud']} baud, {lp['size']} B: "
                        f"{a:.3f} -> {b:.3f} ms ({(b / a - 1) * 100:+.0f} %)"
                    )
    old_cyc = {(r["estimator"], r["mode"]): r for r in old.get("estimators", []) if "cycles" in r}
    for r in new.get("estimators", []):
        before = old_cyc.get((r["estimator"], r["mode"]))
        if before and "cycles" in r:
            a, b = before["cycles"]["median"], r["cycles"]["median"]
            if a and b > a * (1 + slack):
                lines.append(
                    f"{r['estimator']} {r['mode']}: median {a:.0f} -> {b:.0f} cycles "
                    f"({(b / a - 1) * 100:+.0f} %)"
                )
    return lines


def save(figures: dict[str, Any], path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(figures, indent=2, default=str))
