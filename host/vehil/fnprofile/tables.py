"""A profile as tables: the flat table per function, the hottest source lines and the
windows' totals, for the terminal (rich) and for Markdown reports."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
from rich.markup import escape
from rich.table import Table

from vehil.fnprofile.elfmap import Line
from vehil.fnprofile.model import Profile
from vehil.paths import DATA_ROOT


def _mmm(x: np.ndarray, per: int) -> tuple[str, str, str]:
    x = x / per
    return f"{x.min():,.0f}", f"{np.median(x):,.0f}", f"{x.max():,.0f}"


def flat_rows(profile: Profile, limit: int = 30) -> list[list[str]]:
    """function, self and inclusive min/median/max, calls median/max, share."""
    per = profile.per
    whole = float(np.median(profile.window_cycles)) / per or 1.0
    rows = []
    for s in profile.function_stats()[:limit]:
        if not s.self.any() and not s.calls.any():
            continue
        calls = s.calls / per
        rows.append(
            [
                s.label,
                *_mmm(s.self, per),
                *_mmm(s.inclusive, per),
                f"{np.median(calls):,.0f}" if per == 1 else f"{calls.mean():,.1f}",
                f"{calls.max():,.0f}" if per == 1 else "",
                f"{np.median(s.self) / per / whole * 100:.1f} %",
            ]
        )
    return rows


FLAT_HEADER = [
    "function",
    "self min",
    "self median",
    "self max",
    "incl. min",
    "incl. median",
    "incl. max",
    "calls median",
    "calls max",
    "share",
]


def summary_lines(profile: Profile, result_cycles: np.ndarray | None = None) -> list[str]:
    per = profile.per
    w = profile.window_cycles / per
    irq = profile.interrupt_cycles / per
    unit = {"step": "step", "frame": "frame", "exchange": "exchange"}.get(profile.what, "run")
    n = profile.windows * per
    lines = [
        f"{n:,} {unit}{'s' if n != 1 else ''}: {w.min():,.0f} / {np.median(w):,.0f} / "
        f"{w.max():,.0f} cycles (min / median / max) counted per {unit}, of which interrupts "
        f"that landed in it {irq.min():,.0f} / {np.median(irq):,.0f} / {irq.max():,.0f}"
    ]
    idle = profile.function(profile.idle) if profile.idle else None
    if idle is not None:
        busy = (profile.window_cycles - idle.self) / per
        lines.append(
            f"  not waiting (all but {idle.name}'s own cycles, the idle loop): "
            f"median {np.median(busy):,.0f} cycles per {unit}"
        )
    for name, c in sorted(profile.interrupts().items()):
        c = c / per
        lines.append(f"  {name}: median {np.median(c):,.0f}, max {c.max():,.0f} cycles per {unit}")
    if result_cycles is not None and len(result_cycles) == profile.windows:
        d = result_cycles - profile.window_cycles
        values, counts = np.unique(d, return_counts=True)
        most = int(values[np.argmax(counts)])
        lines.append(
            f"RESULT cycles - counted cycles: {most:+d} in {int(counts.max())} of {len(d)} steps "
            f"(the probe's read of Timer1 and the call's set-up outside the window)"
            + (
                ""
                if len(values) == 1
                else f"; range {int(d.min()):+d} .. {int(d.max()):+d} "
                "(interrupts between the probe and the call)"
            )
        )
    return lines


def flat_table(profile: Profile, title: str, limit: int = 30) -> Table:
    t = Table(title=title)
    for i, col in enumerate(FLAT_HEADER):
        t.add_column(col, justify="left" if i == 0 else "right")
    for row in flat_rows(profile, limit):
        t.add_row(escape(row[0]), *row[1:])  # "[libgcc]" is text, not markup
    t.caption = " ".join(
        [
            "self: the function's own instructions; incl.: with what it calls; cycles per",
            f"{profile.what}; share: median self of the median {profile.what}",
        ]
    )
    return t


def lines_table(profile: Profile, limit: int = 15) -> Table:
    t = Table(title=f"hottest source lines (cycles per {profile.what}, mean)")
    for col in ("line", "function", "cycles", "share"):
        t.add_column(col, justify="left" if col in ("line", "function") else "right")
    n = profile.windows * profile.per
    total = float(profile.window_cycles.sum()) or 1.0
    for ln in profile.hot_lines(limit):
        where = f"{ln.line.file}:{ln.line.line}" if ln.line else "(no line table)"
        t.add_row(
            where, escape(ln.function), f"{ln.cycles / n:,.1f}", f"{ln.cycles / total * 100:.1f} %"
        )
    return t


def markdown(
    profile: Profile,
    title: str,
    result_cycles: np.ndarray | None = None,
    png: str | None = None,
    limit: int = 30,
) -> str:
    out = [f"## {title}", ""]
    out += [f"{line}  " for line in summary_lines(profile, result_cycles)] + [""]
    if png:
        out += [
            f"![flame graph, the mean {profile.what}]({png})",
            "",
            f"![flame graph, {profile.what} {profile.median_window} (the median one)]"
            f"({png.replace('.png', '-median.png')})",
            "",
        ]
    out.append("| " + " | ".join(FLAT_HEADER) + " |")
    out.append("|" + "---|" * len(FLAT_HEADER))
    out += ["| " + " | ".join(r) + " |" for r in flat_rows(profile, limit)]
    out += ["", "| line | function | cycles | share |", "|---|---|---|---|"]
    n = profile.windows * profile.per
    total = float(profile.window_cycles.sum()) or 1.0
    for ln in profile.hot_lines(15):
        where = f"`{ln.line.file}:{ln.line.line}`" if ln.line else "(no line table)"
        out.append(
            f"| {where} | {ln.function} | {ln.cycles / n:,.1f} | {ln.cycles / total * 100:.1f} % |"
        )
    return "\n".join(out) + "\n"


def figures(profile: Profile, files: dict | None = None) -> dict:
    """The profile's figures for programs (`--json`): cycles per window of each function."""

    def mmm(x: np.ndarray) -> dict[str, float]:
        x = x / profile.per
        return {"min": float(x.min()), "median": float(np.median(x)), "max": float(x.max())}

    return {
        "per": profile.what,
        "windows": profile.windows * profile.per,
        "cycles": mmm(profile.window_cycles),
        "interrupts": {k: mmm(v) for k, v in profile.interrupts().items()},
        "functions": [
            {
                "name": s.name,
                "library": s.library,
                "self": mmm(s.self),
                "inclusive": mmm(s.inclusive),
                "calls": mmm(s.calls),
            }
            for s in profile.function_stats()
        ],
        "lines": [
            {
                "file": ln.line.file if ln.line else None,
                "line": ln.line.line if ln.line else None,
                "function": ln.function,
                "cycles": ln.cycles / (profile.windows * profile.per),
            }
            for ln in profile.hot_lines(30)
        ],
        "files": {k: str(v) for k, v in (files or {}).items()},
    }


# The link's parts, by the code that does them: the CRC's lines (the assembly loops'
# CRC32C_BYTE, proto/crc32c.h's inline update); the UART served in the frame loops at
# 2 Mbaud, where they run with interrupts off (firmware/src/uart.h: the loops' lines
# of the macros that test, serve and switch); the loops of firmware/src/frame_avr.S
# less both (copying a request's bytes, COBS-encoding a reply and its CRC into the TX
# ring).
_CRC_MACRO = "CRC32C_BYTE"
_CRC_HEADER = "firmware/lib/proto/crc32c.h"
_SERVE_MACROS = ("UART_POLL", "SERVE_STUB", "IF_POLLED", "POLLED_BEGIN", "POLLED_END")
_FRAME_LOOPS = ("frame_rx_bytes", "frame_tx_run", "frame_tx_crc", "frame_tx_frame")
EXCHANGE_PARTS = (
    "RX interrupts",
    "TX interrupts",
    "UART served in the frame loops",
    "CRC-32C",
    "COBS and copying",
    "fetch, dispatch, handler, the rest",
    "not waiting",
)


@cache
def _source(path: Path) -> tuple[str, ...]:
    return tuple(path.read_text().splitlines()) if path.exists() else ()


def _macro(line: Line | None) -> str:
    """The assembly source line's instruction or macro, without its label ('' for C)."""
    if line is None or not line.file.endswith(".S"):
        return ""
    text = _source(DATA_ROOT / line.file)
    words = text[line.line - 1].split(";")[0].split() if 0 < line.line <= len(text) else []
    return words[1 if words and words[0].endswith(":") and len(words) > 1 else 0] if words else ""


def _is_crc(line: Line | None) -> bool:
    return (line is not None and line.file == _CRC_HEADER) or _macro(line) == _CRC_MACRO


def exchange_parts(profile: Profile) -> dict[str, float]:
    """Cycles per exchange by part, from a `--ping SIZE --per exchange` profile."""
    per = profile.windows * profile.per
    irq = profile.interrupts()
    rx = float(irq.get("interrupt USART0_RX", np.zeros(1)).sum()) / per
    tx = float(irq.get("interrupt USART0_UDRE", np.zeros(1)).sum()) / per
    lines = profile.hot_lines(len(profile.pc_cycles))
    crc_lines = [ln for ln in lines if _is_crc(ln.line)]
    crc = sum(ln.cycles for ln in crc_lines) / per
    crc_in_loops = sum(ln.cycles for ln in crc_lines if ln.function in _FRAME_LOOPS) / per
    in_loops = [ln for ln in lines if ln.function in _FRAME_LOOPS]
    served = sum(ln.cycles for ln in in_loops if _macro(ln.line) in _SERVE_MACROS) / per
    loops = sum(float(s.self.sum()) for s in profile.function_stats() if s.name in _FRAME_LOOPS)
    cobs = loops / per - crc_in_loops - served
    idle = profile.function(profile.idle) if profile.idle else None
    busy = float((profile.window_cycles - (idle.self if idle else 0)).sum()) / per
    values = (rx, tx, served, crc, cobs, busy - rx - tx - served - crc - cobs, busy)
    return dict(zip(EXCHANGE_PARTS, values, strict=True))


def parts_table(
    parts: dict[int, dict[str, float]], board: str, window: int = 1, baud: int | None = None
) -> Table:
    how = "stop-and-wait" if window == 1 else f"window {window}"
    at = f", {baud:,} baud" if baud else ""
    t = Table(title=f"one PING exchange by part on {board}, {how}{at} (cycles per exchange)")
    t.add_column("part")
    for size in parts:
        t.add_column(f"{size} B", justify="right")
    for name in EXCHANGE_PARTS:
        t.add_row(name, *(f"{p[name]:,.0f}" for p in parts.values()))
    return t
