"""`vehil profile`'s tables and plots."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rich.table import Table


def uart_table(points: list[dict[str, Any]]) -> Table:
    t = Table(title="UART settings at 16 MHz (U2X): chip figures")
    for col in ("baud", "UBRR", "actual", "error"):
        t.add_column(col, justify="right")
    for p in points:
        err = f"{p['error_pct']:+.2f} %"
        t.add_row(
            f"{p['baud']:,}",
            str(p["ubrr"]),
            f"{p['actual']:,.0f}",
            err if abs(p["error_pct"]) < 2.5 else f"[red]{err}[/]",
        )
    return t


def latency_table(points: list[dict[str, Any]], board: str) -> Table:
    t = Table(
        title=f"{board}: stop-and-wait PING round trips (host clock, ms); handling: board time "
        "from a frame's end to its reply queued (µs at 16 MHz)"
    )
    for col in (
        "baud",
        "payload B",
        "wire",
        "p50",
        "p95",
        "p99",
        "max",
        "p99/wire",
        "board p50",
        "handling µs",
        "CRC/COBS/overrun",
    ):
        t.add_column(col, justify="right")
    for p in points:
        if "error" in p:
            t.add_row(f"{p['baud']:,}", "", "", f"[red]{p['error']}[/]")
            continue
        for lp in p["latency"]:
            if "error" in lp:
                t.add_row(f"{p['baud']:,}", str(lp["size"]), "", f"[red]{lp['error']}[/]")
                continue
            r = lp["rtt_ms"]
            b = lp["board_interval_ms"]
            t.add_row(
                f"{p['baud']:,}",
                str(lp["size"]),
                f"{lp['wire_ms']:.3f}",
                f"{r['p50']:.3f}",
                f"{r['p95']:.3f}",
                f"{r['p99']:.3f}",
                f"{r['max']:.3f}",
                f"{lp['p99_over_wire']:.2f}",
                f"{b['p50']:.3f}" if b else "-",
                f"{lp['frame_cycles'] / 16:.0f}",
                f"{lp['crc_errors']}/{lp['cobs_errors']}/{lp['overruns']}",
            )
    return t


def throughput_table(points: list[dict[str, Any]], board: str) -> Table:
    t = Table(title=f"{board}: windowed PING streaming, 16-byte payloads")
    t.add_column("baud", justify="right")
    windows = [tp["window"] for tp in points[0].get("throughput", [])] if points else []
    for w in windows:
        t.add_column(f"window {w}", justify="right")
    for p in points:
        cells = []
        for tp in p.get("throughput", []):
            cells.append(
                f"[red]{tp['error'][:30]}[/]"
                if "error" in tp
                else f"{tp['frames_s']:,.0f}/s {tp['line_fraction'] * 100:.0f} % "
                f"({tp['board_line_fraction'] * 100:.0f} %)"
            )
        t.add_row(f"{p['baud']:,}", *cells)
    t.caption = (
        "frames/s (host clock) and their share of the line rate (bytes x 10 / baud); "
        "in brackets the share by the board's clock"
    )
    return t


def board_cost_table(rows: list[dict[str, Any]], board: str) -> Table:
    t = Table(title=f"{board}: board cycles per streamed PING exchange, and the line share")
    for col in (
        "baud",
        "payload B",
        "wire B in/out",
        "board cycles",
        "with the wire",
        "requests already in",
        "last byte to reply queued",
        "line share",
    ):
        t.add_column(col, justify="right")
    for r in rows:
        t.add_row(
            f"{r['baud']:,}",
            str(r["size"]),
            f"{r['request_bytes']}/{r['reply_bytes']}",
            f"{r['board_cycles']:,.0f}",
            f"{r['cycles']:,.0f}",
            f"{r['arrived_cycles']:,.0f}",
            f"{r['handling_cycles']:,.0f}",
            f"{r['line_share'] * 100:.0f} %",
        )
    t.caption = (
        "board cycles: PONG timestamps' spacing over bursts of PINGs sent at once, while "
        "later requests still arrive at the line rate (the host never the bottleneck); with "
        "the wire: no less than the reply's time on the wire (10 bits a byte); requests already "
        "in: the board's spacing once every request is in the RX ring; line share: of the "
        "10-bit line rate"
    )
    return t


def _budget_cell(row: dict[str, Any]) -> str:
    if row.get("budget") is None:
        return "–"
    if row["within_budget"]:
        return f"[green]{row['budget']:,}[/]"
    return f"[red]{row['budget']:,} MISSED[/]"


def estimator_table(rows: list[dict[str, Any]], board: str) -> Table:
    t = Table(
        title=f"{board}: estimators, cycles per step (chip figures on simavr or a real board)"
    )
    for col in (
        "estimator",
        "mode",
        "min",
        "median",
        "budget",
        "max",
        "max µs",
        "flash B",
        "RAM B",
        "paper Hz",
        "max Hz @1M stop&wait",
        "pipelined",
        "real Mega",
    ):
        t.add_column(col, justify="right" if col not in ("estimator", "mode") else "left")
    for r in rows:
        if "error" in r:
            t.add_row(r["estimator"], r["mode"], f"[yellow]{r['error'][:60]}[/]")
            continue
        c = r["cycles"]
        rate = r["rates"]["1000000"]
        ok = rate["stop_and_wait_hz"] >= r["paper_hz"]
        t.add_row(
            r["estimator"],
            r["mode"],
            f"{c['min']:,}",
            f"{c['median']:,.0f}",
            _budget_cell(r),
            f"{c['max']:,}",
            f"{r['step_us_max']:,.0f}",
            f"{r['image_flash']:,}" if "image_flash" in r else "n/a",
            f"{r['image_ram']:,}" if "image_ram" in r else "n/a",
            f"{r['paper_hz']:g}",
            f"[{'green' if ok else 'red'}]{rate['stop_and_wait_hz']:,.0f}[/]",
            f"{rate['pipelined_hz']:,.0f}",
            f"{rate['real_board_hz']:,.0f}",
        )
    t.caption = (
        "cycles: stop-and-wait, so no receive interrupt lands in a step; budget: the spec's, "
        "against the median (red: missed). "
        "max Hz: 1 / (wire + worst step) stop-and-wait; pipelined: 1 / max(longer frame, step); "
        "real Mega adds the 16U2's 4.1 ms flush. flash/RAM (--sizes): what the "
        "estimator adds to the image, built with and without it (its state counts where it "
        "is the largest in the shared union)."
    )
    return t


def plots(figures: dict[str, Any], out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    made = []
    sweep = [p for p in figures.get("sweep", []) if "latency" in p]
    if sweep:
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for size in sorted({lp["size"] for p in sweep for lp in p["latency"]}):
            pts = [
                (p["baud"], lp)
                for p in sweep
                for lp in p["latency"]
                if lp["size"] == size and "rtt_ms" in lp
            ]
            if not pts:
                continue
            bauds = [b for b, _ in pts]
            line = ax.plot(
                bauds, [lp["rtt_ms"]["p50"] for _, lp in pts], "o-", label=f"{size} B p50"
            )[0]
            ax.plot(
                bauds,
                [lp["rtt_ms"]["p99"] for _, lp in pts],
                "^:",
                color=line.get_color(),
                label=f"{size} B p99",
            )
            ax.plot(
                bauds,
                [lp["wire_ms"] for _, lp in pts],
                "--",
                color=line.get_color(),
                alpha=0.5,
                label=f"{size} B wire limit",
            )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("baud")
        ax.set_ylabel("round trip [ms]")
        ax.set_title(f"{figures['board']}: latency vs baud")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7, ncol=2)
        fig.tight_layout()
        made.append(out / "latency_vs_baud.png")
        fig.savefig(made[-1], dpi=110)
        plt.close(fig)

        fig, ax = plt.subplots(figsize=(8, 4.5))
        for p in sweep:
            tps = [tp for tp in p["throughput"] if "frames_s" in tp]
            ax.plot(
                [tp["window"] for tp in tps],
                [tp["line_fraction"] * 100 for tp in tps],
                "o-",
                label=f"{p['baud']:,} baud",
            )
        ax.set_xscale("log", base=2)
        ax.set_xlabel("frames in flight (window)")
        ax.set_ylabel("share of line rate [%]")
        ax.set_title(f"{figures['board']}: throughput vs window")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        made.append(out / "throughput_vs_window.png")
        fig.savefig(made[-1], dpi=110)
        plt.close(fig)
    rows = [r for r in figures.get("estimators", []) if "cycles" in r]
    if rows:
        fig, ax = plt.subplots(figsize=(8, 0.4 * len(rows) + 1.5))
        labels = [f"{r['estimator']} {r['mode']}" for r in rows]
        med = [r["cycles"]["median"] for r in rows]
        lo = [r["cycles"]["median"] - r["cycles"]["min"] for r in rows]
        hi = [r["cycles"]["max"] - r["cycles"]["median"] for r in rows]
        ax.barh(labels, med, xerr=[lo, hi], color="tab:green", capsize=3)
        ax.set_xscale("log")
        ax.set_xlabel("cycles per step (median, min-max)")
        ax.axvline(160_000, color="tab:red", ls="--", lw=1, label="10 ms at 16 MHz")
        ax.legend(fontsize=8)
        ax.set_title(f"{figures['board']}: cycles per estimator step")
        fig.tight_layout()
        made.append(out / "cycles_per_estimator.png")
        fig.savefig(made[-1], dpi=110)
        plt.close(fig)
    return made
