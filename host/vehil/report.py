"""Reports: a rich table for the terminal; Markdown with PNG plots and JSON figures on disk."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from rich.markup import escape
from rich.table import Table

from vehil.compare import Figures, OutputFigures, Series
from vehil.scenario import Tolerance


def _g(x: float | None, unit: str = "") -> str:
    if x is None:
        return "-"
    return f"{x:.4g}{(' ' + unit) if unit else ''}"


def verdict_cell(o: OutputFigures, figures: Figures) -> str:
    """One output's verdict, the same words in the console and in report.md; a run that
    stopped short passes an output only over the samples it checked, and says so."""
    if o.passed and figures.expected is not None and figures.samples < figures.expected:
        return f"pass over {figures.samples:,} of {figures.expected:,} samples only"
    if o.passed is None:
        if o.reference.rmse is None:
            return "not checked (no samples)"
        if o.reference.tolerance is not None:
            return "not checked (no sample from the tolerance's start on)"
        return "not checked (no tolerance)"
    if o.passed is False:
        return "FAIL " + ", ".join(o.failed())
    words = "pass, bit-exact" if o.bit_exact is not None and o.bit_exact.passed else "pass"
    missing = o.not_checked()
    return words + (f"; {'/'.join(missing)} not checked" if missing else "")


def _cells(o: OutputFigures, ref_word: str) -> tuple[str, str, str, str]:
    ref, truth = o.reference, o.truth
    tol_s = "-" if ref.tolerance is None else _tolerance(ref.tolerance, ref_word)
    truth_s = "-" if truth is None else f"{_g(truth.rmse)} / {_g(truth.reference_rmse)}"
    if truth is not None and truth.from_s:
        truth_s += f" from {truth.from_s:g} s"
    worst = f" ({ref.worst_k})" if ref.worst_k is not None else ""
    return tol_s, _g(ref.rmse), _g(ref.max_abs) + worst, truth_s


def summary_table(figures: Figures, title: str) -> Table:
    t = Table(title=title)
    t.add_column("output")
    for col in (
        "tolerance",
        "RMSE vs ref",
        "max |err| (k)",
        "RMSE vs truth\nboard / ref",
        "result",
    ):
        t.add_column(col, justify="right")
    for name, o in figures.outputs.items():
        style = {True: "green", False: "bold red", None: "yellow"}[o.passed and figures.passed]
        t.add_row(
            f"{name} [{o.unit}]" if o.unit else name,
            *_cells(o, "|ref|"),
            f"[{style}]{escape(verdict_cell(o, figures))}[/]",
        )
    c, r = figures.cycles, figures.rtt_ms
    flags = ", ".join(f"{k} x{v}" for k, v in figures.status.items() if v) or "none"
    t.caption = (
        f"{_samples(figures)}; cycles/step min {_g(c['min'])} median {_g(c['median'])} "
        f"max {_g(c['max'])}{_stack(figures)}; round trip p50 {_g(r['p50'])} ms "
        f"p99 {_g(r['p99'])} ms; late {figures.late}; status flags: {flags}"
    )
    return t


def _samples(figures: Figures) -> str:
    """How many samples the figures cover, of how many the run was to have."""
    of = f" of {figures.expected:,}" if figures.expected is not None else ""
    return f"{figures.samples:,}{of} samples"


def verdict_line(figures: Figures) -> str:
    """The run's verdict for the console (rich markup)."""
    style = "bold green" if figures.passed else "bold red"
    v = figures.verdict
    return f"[{style}]{v.word}[/]" + (f": {escape(v.reason)}" if v.reason else "")


def _stack(figures: Figures) -> str:
    b = figures.stack_bytes
    return "" if b is None else f"; stack high-water {b:,} B since boot"


def _tolerance(tol: Tolerance, ref: str) -> str:
    since = f" from {tol.from_s:g} s" if tol.from_s else ""
    if tol.from_samples:
        since += f"{' and' if since else ' from'} sample {tol.from_samples}"
    return f"{tol.abs:g} + {tol.rel:g}·{ref}{since}"


def _output_plot(name: str) -> tuple[str, str]:
    return f"{name}: estimate vs reference vs truth, and errors", f"{name}.png"


def _histograms(s: Series) -> list[tuple[str, np.ndarray, str, str]]:
    """What, the data, its axis label and the file: those a run has data for."""
    hists = [
        ("cycles per step", s.cycles, "cycles", "cycles.png"),
        ("round trip (host clock)", s.rtt_s * 1e3, "ms", "latency.png"),
    ]
    return [h for h in hists if len(h[1])]


def _plot_names(s: Series) -> list[tuple[str, str]]:
    """Caption and file of each plot `_plots` draws, in order."""
    return [_output_plot(n) for n in s.names] + [(h[0], h[3]) for h in _histograms(s)]


def _plots(s: Series, out: Path, every: int = 1) -> None:
    """`every`: the series keeps every that many samples of the run (a long run's plots
    are drawn from a bounded number of points; histograms count each kept one that often)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(s.board)
    t = s.t[:n]
    for j, name in enumerate(s.names):
        unit = s.units.get(name, "")
        has_truth = name in s.truth
        rows = 3 if has_truth else 2
        fig, axes = plt.subplots(
            rows,
            1,
            figsize=(9, 2.2 * rows + 1.2),
            sharex=True,
            height_ratios=[2] + [1] * (rows - 1),
        )
        ax = axes[0]
        if has_truth:
            ax.plot(t, s.truth[name][:n], color="0.6", lw=2.5, label="truth")
        ax.plot(t, s.reference[:n, j], color="tab:blue", lw=1.2, label="float64 reference")
        ax.plot(t, s.board[:, j], color="tab:orange", lw=0.9, ls="--", label="board")
        ax.set_ylabel(f"{name} [{unit}]")
        ax.legend(loc="best", fontsize=8)
        # Numeric error (board vs reference) and estimation error (vs truth) differ by
        # orders of magnitude: each gets its own axis.
        errors = [("board - reference", s.board[:, j] - s.reference[:n, j], "tab:red")]
        if has_truth:
            errors.append(("board - truth", s.board[:, j] - s.truth[name][:n], "0.3"))
        for ax_err, (label, err, color) in zip(axes[1:], errors, strict=True):
            ax_err.plot(t, err, color=color, lw=0.7)
            ax_err.set_ylabel(f"{label}\n[{unit}]", fontsize=8)
        for a in axes:
            a.grid(alpha=0.3)
        axes[-1].set_xlabel("t [s]")
        fig.tight_layout()
        fig.savefig(out / _output_plot(name)[1], dpi=110)
        plt.close(fig)
    for what, data, xlabel, file in _histograms(s):
        fig, ax = plt.subplots(figsize=(7, 3.5))
        ax.hist(data, bins=60, color="tab:purple", weights=np.full(len(data), every))
        ax.set_xlabel(xlabel)
        ax.set_ylabel("samples")
        ax.set_title(what)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(out / file, dpi=110)
        plt.close(fig)


PLOT_POINTS = 20_000  # samples a run's plots are drawn from, at most


def _firmware(info: dict[str, Any]) -> str | None:
    """The build id as INFO and the recording give it, `+dirty` included."""
    if info.get("build_id") is None:
        return None
    return f"{info['build_id']:08x}{'+dirty' if info.get('build_dirty') else ''}"


def run_context(run: Any, title: str, input_note: str | None = None) -> dict[str, Any]:
    """What report.md and figures.json say of a vehil.runner.Run beside its figures."""
    sc = run.scenario
    return {
        "title": title,
        "scenario": sc.name,
        "board": run.board,
        "mode": sc.mode,
        "firmware": _firmware(run.info),
        "input": input_note,
        "ended": run.ended,
        "error": run.error,
        "wall_s": round(run.wall_s, 3),
        "samples_per_s": round(run.done / run.wall_s if run.wall_s else 0.0, 1),
        "recording": str(run.recording) if run.recording else None,
        "log_inputs": run.context.get("log_inputs"),
        "log_notes": run.context.get("log_notes"),
        "board_resets": [
            {"at_sample": r.at_sample, "recovery_s": round(r.recovery_s, 3)} for r in run.resumes
        ],
    }


def write_run(run: Any, context: dict[str, Any]) -> Path:
    """A recorded run's report beside its recording, its plots from every n-th sample."""
    from vehil.compare import series_from_recording
    from vehil.record import read

    every = max(1, -(-run.figures.samples // PLOT_POINTS))
    s = series_from_recording(read(run.recording, every=every))
    return write(s, run.figures, context, run.recording.parent, every)


def write(s: Series, figures: Figures, context: dict[str, Any], out: Path, every: int = 1) -> Path:
    """report.md, figures.json and PNGs into `out`; returns the Markdown file."""
    out.mkdir(parents=True, exist_ok=True)
    data = {**context, **figures.to_json()}
    (out / "figures.json").write_text(json.dumps(data, indent=2, default=str))
    plots = _plot_names(s)
    lines = [f"# {context.get('title', 'vehil run')}", "", _overall(figures), ""]
    for k in (
        "scenario",
        "board",
        "mode",
        "firmware",
        "input",
        "ended",
        "error",
        "wall_s",
        "recording",
    ):
        if context.get(k) is not None:
            lines.append(f"- **{k}**: " + str(context[k]).replace("\n", "\n  "))
    lines += [
        "",
        "| output | tolerance | RMSE vs ref | max abs vs ref (k) "
        "| RMSE vs truth (board / ref) | result |",
        "|---|---|---|---|---|---|",
    ]
    for name, o in figures.outputs.items():
        cells = [*_cells(o, "abs(ref)"), verdict_cell(o, figures)]
        lines.append(f"| {name} [{o.unit}] | " + " | ".join(cells) + " |")
    c, r = figures.cycles, figures.rtt_ms
    lines += [
        "",
        f"Figures over {_samples(figures)}. Cycles per step: min {_g(c['min'])}, "
        f"median {_g(c['median'])}, max {_g(c['max'])}"
        f"{_stack(figures)}. Round trip: p50 {_g(r['p50'])} ms, p99 {_g(r['p99'])} ms. "
        f"Late samples: {figures.late}.",
        "",
    ]
    lines += _log_table(context)
    for caption, file in plots:
        lines += [f"## {caption}", "", f"![{caption}]({file})", ""]
    md = out / "report.md"
    md.write_text("\n".join(lines))  # before the plots: the slow part, which Ctrl-C may cut
    _plots(s, out, every)
    return md


def _overall(figures: Figures) -> str:
    """The verdict as report.md heads it, on one line."""
    reason = "; ".join(line.strip() for line in figures.verdict.reason.splitlines())
    return f"Overall: **{figures.verdict.word}**" + (f": {reason}" if reason else "")


def _log_table(context: dict[str, Any]) -> list[str]:
    """A replayed log's coverage and timing: per input, its source, unit conversion, rate,
    jitter, gaps, missing and merged samples, and the resampling applied."""
    rows = context.get("log_inputs")
    if not rows:
        return []
    keys = list(dict.fromkeys(k for r in rows for k in r))
    lines = ["## Log inputs", "", "| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(r.get(k, "") for k in keys) + " |" for r in rows]
    return [*lines, "", *(f"- {n}" for n in context.get("log_notes") or ()), ""]


def diff_table(d: dict[str, Any], a: str, b: str) -> Table:
    t = Table(title=f"{b}\nagainst {a}")
    for col in ("output", "identical", "differing samples", "first at k", "max |b - a|"):
        t.add_column(col, justify="right" if col != "output" else "left")
    for name, o in d["outputs"].items():
        t.add_row(
            name,
            "[green]yes[/]" if o["identical"] else "[red]no[/]",
            f"{o['differing_samples']:,}",
            "-" if o["first_difference_k"] is None else str(o["first_difference_k"]),
            f"{o['max_abs']:.4g}",
        )
    ca, cb = d["cycles_median"]["a"], d["cycles_median"]["b"]
    if d["cycles_comparable"]:
        cycles = f"median cycles/step {_g(ca)} -> {_g(cb)}" + (
            f" ({(cb - ca) / ca * 100:+.1f} %)" if ca and cb else ""
        )
    else:
        board_a, board_b = d["boards"]
        cycles = (
            f"median cycles/step {_g(ca)} on {board_a}, {_g(cb)} on {board_b}: "
            "different boards, not compared"
        )
    t.caption = (
        f"{d['samples']:,} samples compared (lengths {d['lengths'][0]:,} and {d['lengths'][1]:,}); "
        + cycles
    )
    return t
