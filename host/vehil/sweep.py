"""`vehil sweep`: Monte Carlo over a scenario's plant, through the runner on any board.

Each drive is the scenario with its perturbed plant parameters drawn anew and its own
noise seed, run and judged exactly as `vehil run` would (runner.run, compare.evaluate).
The estimator keeps its nominal parameters, so the sweep measures model mismatch;
`matched` hands it the drawn values of the parameters it shares by name with the plant.
A nominal drive (no perturbation, the scenario's seed) is run first as the baseline.
"""

from __future__ import annotations

import dataclasses
import json
import signal
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from vehil import campaign, plants, record, runner
from vehil.boards import Board
from vehil.compare import Figures
from vehil.errors import PlantLimit, Terminated
from vehil.paths import runs_dir
from vehil.perturb import Perturbation
from vehil.protocol.schema import SCHEMA
from vehil.results import Case
from vehil.scenario import Scenario, ScenarioError


@dataclass(frozen=True)
class Drive:
    index: int  # 0 is the nominal drive
    seed: int
    drawn: dict[str, float]  # the perturbed plant parameters' values
    figures: Figures
    # Per output in metres, where the estimator's truth is band-limited (in_band_errors):
    # RMS error against the in-band truth, and that truth's RMS (the all-zero estimate's).
    in_band: dict[str, dict[str, float]] = dataclasses.field(default_factory=dict)


IN_BAND = "RMS vs in-band truth"
ZERO = "in-band truth RMS (zero estimate)"
MEASURES = ("max abs error vs float64", "RMS vs truth", "RMS vs truth, float64 ref", IN_BAND, ZERO)


def in_band_errors(scenario: Scenario, recording: Path) -> dict[str, dict[str, float]]:
    """For an estimator whose spec has an `in_band` hook (its estimates see the truth only
    through a band, e.g. the accelerometer conditioning of the ESO and the KF-UI): each
    output in metres against that band's truth, from score_from_s, and the in-band truth's
    own RMS, which is what estimating nothing scores. Empty for any other estimator."""
    band = scenario.estimator.extra.get("in_band")
    if not callable(band):
        return {}
    rec = record.read(recording)
    k0 = int(np.searchsorted(rec.data["t"], scenario.score_from_s - 1e-9))
    found = {}
    for o in scenario.estimator.outputs:
        column = f"truth.{o.name}"
        if o.unit != "m" or column not in rec.data:
            continue
        truth = band(rec.data[column], scenario.params)[k0:]
        error = rec.data[f"board.{o.name}"][k0:] - truth
        found[o.name] = {
            IN_BAND: float(np.sqrt(np.mean(error**2))),
            ZERO: float(np.sqrt(np.mean(truth**2))),
        }
    return found


@dataclass(frozen=True)
class Sweep:
    scenario: Scenario
    board: str
    perturbations: dict[str, Perturbation]
    matched: tuple[str, ...]  # estimator parameters that followed the plant
    nominal: Drive
    drives: list[Drive]
    out: Path
    stopped: str | None = None  # why it ended before its last drive (Ctrl-C, SIGTERM)
    stop_signal: int | None = None

    @staticmethod
    def _measures(d: Drive, name: str) -> dict[str, float | None]:
        o = d.figures.outputs[name]
        found: dict[str, float | None] = {"max abs error vs float64": o.reference.max_abs}
        if o.truth is not None:
            found["RMS vs truth"] = o.truth.rmse
            found["RMS vs truth, float64 ref"] = o.truth.reference_rmse
        found.update(d.in_band.get(name, {}))
        return found

    def errors(self) -> dict[str, dict[str, np.ndarray]]:
        """Per output, per measure, one value per perturbed drive (NaN where none)."""
        found: dict[str, dict[str, np.ndarray]] = {}
        for name in self.nominal.figures.outputs:
            each = [self._measures(d, name) for d in self.drives]
            found[name] = {
                m: np.array([np.nan if x.get(m) is None else x[m] for x in each], dtype=np.float64)
                for m in MEASURES
                if all(m in x for x in each)
            }
        return found

    def beats_zero(self) -> dict[str, int]:
        """Per output scored in band: on how many drives it beats estimating nothing."""
        return {
            name: int(np.sum(found[IN_BAND] < found[ZERO]))
            for name, found in self.errors().items()
            if IN_BAND in found
        }

    def distributions(self) -> list[dict[str, Any]]:
        rows = []
        for name, measures in self.errors().items():
            o = self.nominal.figures.outputs[name]
            nominal = self._measures(self.nominal, name)
            for measure, x in measures.items():
                ok = x[np.isfinite(x)]
                rows.append(
                    {
                        "output": name,
                        "unit": o.unit,
                        "measure": measure,
                        "nominal": nominal.get(measure),
                        "median": float(np.median(ok)) if len(ok) else None,
                        "p95": float(np.percentile(ok, 95)) if len(ok) else None,
                        "worst": float(ok.max()) if len(ok) else None,
                        "worst_drive": self.drives[int(np.nanargmax(x))].index if len(ok) else None,
                        "drives": len(ok),
                    }
                )
        return rows

    def flags(self) -> list[dict[str, Any]]:
        """Per status bit: on how many drives it fired, and on what share of all samples."""
        samples = sum(d.figures.samples for d in self.drives)
        rows = []
        for bit in SCHEMA.status:
            counts = [d.figures.status.get(bit, 0) for d in self.drives]
            rows.append(
                {
                    "flag": bit,
                    "nominal_samples": self.nominal.figures.status.get(bit, 0),
                    "drives": sum(c > 0 for c in counts),
                    "of": len(self.drives),
                    "sample_share": sum(counts) / samples if samples else None,
                }
            )
        return rows

    def verdicts(self) -> dict[str, int]:
        words: dict[str, int] = {}
        for d in self.drives:
            words[d.figures.verdict.word] = words.get(d.figures.verdict.word, 0) + 1
        return words

    def to_json(self) -> dict[str, Any]:
        return {
            "scenario": self.scenario.name,
            "estimator": self.scenario.estimator.name,
            "mode": self.scenario.mode,
            "board": self.board,
            "perturbations": {
                n: {"how": p.how, "lo": p.lo, "hi": p.hi, "unit": p.unit}
                for n, p in self.perturbations.items()
            },
            "matched": list(self.matched),
            "stopped": self.stopped,
            "distributions": self.distributions(),
            "flags": self.flags(),
            "verdicts": self.verdicts(),
            "beats_zero_in_band": self.beats_zero(),
            "drives": [
                {
                    "index": d.index,
                    "seed": d.seed,
                    "drawn": d.drawn,
                    "verdict": str(d.figures.verdict),
                    "outputs": {
                        n: {
                            "max_abs_vs_ref": o.reference.max_abs,
                            "rms_vs_truth": o.truth.rmse if o.truth else None,
                        }
                        for n, o in d.figures.outputs.items()
                    },
                    "in_band": d.in_band,
                    "status": d.figures.status,
                }
                for d in (self.nominal, *self.drives)
            ],
        }


def perturbations(scenario: Scenario, extra: dict[str, dict[str, Any]]) -> dict[str, Perturbation]:
    """The scenario's [sweep], with `extra` (from the command line) over it, checked."""
    from vehil.perturb import declare

    if scenario.plant is None:
        raise ScenarioError(f"{scenario.path}: a sweep varies a plant; this scenario replays a log")
    spec = plants.get(scenario.plant)
    found = dict(scenario.sweep)
    try:
        for name, table in extra.items():
            found[name] = declare(name, table, spec.params, scenario.plant_params, spec.name)
    except ValueError as exc:
        raise ScenarioError(str(exc)) from None
    if not found:
        raise ScenarioError(
            f"{scenario.path}: nothing to vary: give a [sweep] table in the scenario "
            "(e.g. mass = {rel = 0.15}) or --vary NAME:rel=0.15"
        )
    return found


def _drive(
    scenario: Scenario, index: int, seed: int, drawn: dict[str, float], matched: tuple[str, ...]
) -> Scenario:
    params = {**scenario.params, **{n: drawn[n] for n in matched if n in drawn}}
    if matched:
        params = scenario.estimator.param_values(params)  # the drawn values in its ranges too
    return dataclasses.replace(
        scenario,
        name=f"{scenario.name}-{index:03d}",
        seed=seed,
        plant_params={**scenario.plant_params, **drawn},
        params=params,
    )


def run(
    scenario: Scenario,
    found: dict[str, Perturbation],
    drives: int,
    board: str | Board = "native",
    *,
    matched: bool = False,
    seed: int | None = None,
    out: Path | None = None,
    console: Console | None = None,
    client: Any = None,
) -> Sweep:
    """The nominal drive, then `drives` perturbed ones; drive i's plant seed is the
    scenario's + i, and the draws come from `seed` (the scenario's by default). With a
    Dask `client` (vehil.campaign) the drives run on its workers, and their figures
    are gathered into an Arrow dataset too (results/)."""
    board_name = board if isinstance(board, str) else board.name
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    out = out or runs_dir() / f"sweep-{scenario.name}-{board_name}-{stamp}"
    shared = tuple(n for n in found if matched and n in {p.name for p in scenario.estimator.params})
    if matched and not shared:
        raise ScenarioError(
            f"--matched: {scenario.estimator.name} shares no parameter with the varied ones "
            f"({', '.join(found)})"
        )
    rng = np.random.default_rng(scenario.seed if seed is None else seed)
    draws: list[dict[str, float]] = [{}] + [
        {n: p.draw(rng) for n, p in found.items()} for _ in range(drives)
    ]
    jobs = [
        campaign.Job(
            f"{scenario.name}-{i:03d}",
            _drive(scenario, i, scenario.seed + i, drawn, shared),
            out / f"drive-{i:03d}" / "run.arrow",
        )
        for i, drawn in enumerate(draws)
    ]

    def said(i: int, figures: Figures) -> None:
        if console is not None:
            console.print(escape(f"drive {i}/{drives}: {figures.verdict}"), highlight=False)

    stopped, stop_signal = None, None
    if client is None:
        quiet = Console(quiet=True)
        figures = []
        for i, job in enumerate(jobs):
            try:
                result = runner.run(job.scenario, board, recording=job.recording, console=quiet)
            except PlantLimit as exc:
                drawn = ", ".join(f"{k} = {v:.4g}" for k, v in draws[i].items()) or "nominal"
                raise PlantLimit(
                    f"drive {i} ({drawn}): {exc}; narrow the sweep's ranges to what the plant "
                    "can model"
                ) from None
            except KeyboardInterrupt as exc:  # between two drives' samples
                stop_signal = getattr(exc, "signum", signal.SIGINT)
            else:
                stop_signal = result.stop_signal
            if stop_signal is not None:
                if i < 2:  # no perturbed drive done: nothing to sum up
                    raise Terminated(stop_signal)
                stopped = (
                    f"interrupted ({signal.Signals(stop_signal).name}) in drive {i}: "
                    f"{i - 1} of {drives} perturbed drives done"
                )
                jobs = jobs[:i]
                break
            figures.append(result.figures)
            said(i, result.figures)
    else:
        campaign.check_board(board_name)
        index = {job.name: i for i, job in enumerate(jobs)}
        done = campaign.run(client, jobs, lambda d: said(index[d.job.name], d.figures))
        figures = [d.figures for d in done]
        extra = [
            {"seed": j.scenario.seed, **{f"drawn.{k}": v for k, v in draws[i].items()}}
            for i, j in enumerate(jobs)
        ]
        campaign.write_dataset(campaign.rows(done, extra), out / "results")
    found_drives = [
        Drive(i, job.scenario.seed, draws[i], f, in_band_errors(job.scenario, job.recording))
        for i, (job, f) in enumerate(zip(jobs, figures, strict=True))
    ]
    return Sweep(
        scenario,
        board_name,
        found,
        shared,
        found_drives[0],
        found_drives[1:],
        out,
        stopped,
        stop_signal,
    )


def cases(s: Sweep) -> list[Case]:
    """Each drive as a test case: its figures, seed and drawn parameters."""
    return [
        Case(
            f"{s.scenario.name}-{d.index:03d}",
            {
                **d.figures.to_json(),
                "scenario": s.scenario.name,
                "board": s.board,
                "mode": s.scenario.mode,
                "seed": d.seed,
                "drawn": d.drawn,
                "recording": str(s.out / f"drive-{d.index:03d}" / "run.arrow"),
            },
        )
        for d in (s.nominal, *s.drives)
    ]


def _g(x: float | None) -> str:
    return "-" if x is None else f"{x:.4g}"


def distribution_table(s: Sweep) -> Table:
    t = Table(title=f"{s.scenario.name}: {len(s.drives)} drives on {s.board}")
    for col in ("output", "measure", "nominal", "median", "p95", "worst (drive)"):
        t.add_column(col, justify="left" if col in ("output", "measure") else "right")
    for r in s.distributions():
        unit = escape(f" [{r['unit']}]") if r["unit"] else ""
        t.add_row(
            r["output"] + unit,
            r["measure"],
            _g(r["nominal"]),
            _g(r["median"]),
            _g(r["p95"]),
            f"{_g(r['worst'])} ({r['worst_drive']})",
        )
    varied = "; ".join(f"{n} {p.how} {p.unit}" for n, p in s.perturbations.items())
    follows = f"; the estimator follows {', '.join(s.matched)}" if s.matched else ""
    verdicts = ", ".join(f"{w} {n}" for w, n in s.verdicts().items())
    t.caption = f"varied: {varied}{follows}; verdicts: {verdicts}{_beats_zero(s)}"
    return t


def _beats_zero(s: Sweep) -> str:
    found = s.beats_zero()
    said = ", ".join(f"{n} on {k}/{len(s.drives)} drives" for n, k in found.items())
    return f"; in band, better than the zero estimate: {said}" if found else ""


def flag_table(s: Sweep) -> Table:
    t = Table(title="status flags (per step, for the estimator as a whole)")
    for col in ("flag", "nominal samples", "drives fired", "share of samples"):
        t.add_column(col, justify="left" if col == "flag" else "right")
    for r in s.flags():
        share = "-" if r["sample_share"] is None else f"{r['sample_share']:.2%}"
        t.add_row(r["flag"], str(r["nominal_samples"]), f"{r['drives']}/{r['of']}", share)
    return t


def _plot(s: Sweep, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    errors = s.errors()
    measures = ["RMS vs truth", "max abs error vs float64"]
    fig, axes = plt.subplots(
        len(measures), len(errors), figsize=(3.2 * len(errors), 5.5), squeeze=False
    )
    for j, (name, found) in enumerate(errors.items()):
        o = s.nominal.figures.outputs[name]
        for i, m in enumerate(measures):
            ax = axes[i][j]
            x = found.get(m)
            if x is None or not np.isfinite(x).any():
                ax.set_axis_off()
                continue
            ax.hist(x[np.isfinite(x)], bins=min(20, max(5, len(x) // 2)), color="tab:blue")
            nominal = o.reference.max_abs if m.startswith("max") else o.truth.rmse  # type: ignore[union-attr]
            if nominal is not None:
                ax.axvline(nominal, color="tab:red", label="nominal drive")
                ax.legend(fontsize=7)
            ax.set_title(f"{name}: {m}", fontsize=8)
            ax.set_xlabel(o.unit, fontsize=8)
    fig.suptitle(f"{s.scenario.name}: {len(s.drives)} drives", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def write(s: Sweep) -> Path:
    """sweep.md, sweep.png and sweep.json in the sweep's folder; returns the Markdown's path."""
    s.out.mkdir(parents=True, exist_ok=True)
    (s.out / "sweep.json").write_text(json.dumps(s.to_json(), indent=1))
    _plot(s, s.out / "sweep.png")
    sc = s.scenario
    lines = [
        f"# Sweep: {sc.name}",
        "",
        *([f"**INTERRUPTED**: {s.stopped}; the figures cover those.", ""] if s.stopped else []),
        f"{sc.estimator.name} ({sc.mode}) on {s.board}, {len(s.drives)} perturbed drives "
        f"and the nominal one; plant {sc.plant}, drive i's noise seed {sc.seed} + i.",
        "",
        "| varied | how | range |",
        "|---|---|---|",
        *(f"| {n} | {p.how} | [{p.lo:g}, {p.hi:g}] {p.unit} |" for n, p in s.perturbations.items()),
        "",
        "The estimator keeps its nominal parameters"
        + (f" except {', '.join(s.matched)}, which follow the plant." if s.matched else "."),
        "",
        "| output | measure | nominal | median | p95 | worst (drive) |",
        "|---|---|---|---|---|---|",
    ]
    for r in s.distributions():
        lines.append(
            f"| {r['output']} [{r['unit']}] | {r['measure']} | {_g(r['nominal'])} | "
            f"{_g(r['median'])} | {_g(r['p95'])} | {_g(r['worst'])} ({r['worst_drive']}) |"
        )
    lines += [
        "",
        "| flag | nominal samples | drives fired | share of samples |",
        "|---|---|---|---|",
    ]
    for r in s.flags():
        share = "-" if r["sample_share"] is None else f"{r['sample_share']:.2%}"
        lines.append(
            f"| {r['flag']} | {r['nominal_samples']} | {r['drives']}/{r['of']} | {share} |"
        )
    verdicts = ", ".join(f"{w} {n}" for w, n in s.verdicts().items())
    lines += [
        "",
        f"Verdicts against the scenario's tolerances: {verdicts}{_beats_zero(s)}.",
        "",
        "![distributions](sweep.png)",
        "",
        "Each drive's recording and figures: drive-NNN/ (000 is the nominal drive).",
        "",
    ]
    md = s.out / "sweep.md"
    md.write_text("\n".join(lines))
    return md
