"""Runs' results for a CI and for a person: JUnit XML (a scenario is a test case, its
figures are properties) and one self-contained HTML file (verdicts, figures, plots
embedded, each run's details, and the trend against a baseline's figures.json).

Both read what each run wrote: its figures.json (the same figures as the console and
report.md) and, for the HTML, the PNGs beside it.
"""

from __future__ import annotations

import base64
import html
import json
import math
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from vehil.errors import VehilError


@dataclass(frozen=True)
class Case:
    """One run: its name (the scenario, or a sweep's drive), its figures as figures.json
    holds them, and the folder with its report and plots (None: no report of its own)."""

    name: str
    figures: dict[str, Any]
    folder: Path | None = None

    @property
    def word(self) -> str:
        return str(self.figures.get("verdict", {}).get("word", "FAILED"))

    @property
    def reason(self) -> str:
        return str(self.figures.get("verdict", {}).get("reason", ""))


def case_from_folder(folder: Path, name: str | None = None) -> Case:
    """A run's folder (its figures.json): the case vehil run wrote."""
    path = folder / "figures.json"
    try:
        figures = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise VehilError(f"{path}: no run's figures to report ({exc})") from None
    return Case(name or str(figures.get("scenario") or folder.name), figures, folder)


def failed_case(name: str, reason: str) -> Case:
    """A run that never started: no figures, its error."""
    return Case(name, {"verdict": {"word": "FAILED", "reason": reason}})


# Figures that say how a run went, and trend from one build to the next.
TREND_KEYS = ("reference.max_abs", "reference.rmse", "truth.rmse")


def flat(figures: dict[str, Any]) -> dict[str, float | int | bool | str]:
    """The figures as name -> value (`outputs.v.truth.rmse`), numbers and flags only;
    tolerances are the scenario's, not the run's, and stay out."""
    found: dict[str, float | int | bool | str] = {}

    def walk(x: Any, prefix: str) -> None:
        if isinstance(x, dict):
            for k, v in x.items():
                if k not in ("tolerance", "exit_status"):
                    walk(v, f"{prefix}{k}.")
        elif isinstance(x, bool | int | float) and x is not None:
            found[prefix[:-1]] = x

    for key in ("samples", "expected", "cycles", "rtt_ms", "late", "stack_bytes", "status"):
        walk({key: figures.get(key)}, "")
    walk({"outputs": figures.get("outputs", {})}, "")
    return found


def _verdicts(cases: Sequence[Case]) -> dict[str, int]:
    words: dict[str, int] = {}
    for c in cases:
        words[c.word] = words.get(c.word, 0) + 1
    return words


def junit(cases: Sequence[Case], suite: str, path: Path) -> Path:
    """JUnit XML: PASS passes; FAIL and NOT CHECKED fail (vehil exits 1 for both);
    FAILED and INTERRUPTED are errors (the run did not complete)."""
    words = _verdicts(cases)
    failures = words.get("FAIL", 0) + words.get("NOT CHECKED", 0)
    errors = sum(n for w, n in words.items() if w in ("FAILED", "INTERRUPTED"))
    total_s = sum(float(c.figures.get("wall_s") or 0.0) for c in cases)
    root = ET.Element("testsuites", name=suite)
    ts = ET.SubElement(
        root,
        "testsuite",
        name=suite,
        tests=str(len(cases)),
        failures=str(failures),
        errors=str(errors),
        skipped="0",
        time=f"{total_s:.3f}",
        timestamp=datetime.now(UTC).isoformat(timespec="seconds"),
    )
    for c in cases:
        tc = ET.SubElement(
            ts,
            "testcase",
            classname=f"vehil.{suite}",
            name=c.name,
            time=f"{float(c.figures.get('wall_s') or 0.0):.3f}",
        )
        props = ET.SubElement(tc, "properties")
        for k, v in {"verdict": c.word, **_context(c.figures), **flat(c.figures)}.items():
            ET.SubElement(props, "property", name=k, value=str(v))
        if c.word in ("FAIL", "NOT CHECKED"):
            ET.SubElement(tc, "failure", message=c.reason, type=c.word).text = c.reason
        elif c.word != "PASS":
            ET.SubElement(tc, "error", message=c.reason, type=c.word).text = c.reason
        if c.folder is not None:
            ET.SubElement(tc, "system-out").text = f"report: {c.folder / 'report.md'}"
    ET.indent(root)
    path.parent.mkdir(parents=True, exist_ok=True)
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)
    return path


def _context(figures: dict[str, Any]) -> dict[str, str]:
    return {
        k: str(figures[k])
        for k in ("board", "mode", "firmware", "recording")
        if figures.get(k) is not None
    }


def load_baseline(path: Path) -> dict[str, dict[str, Any]]:
    """Figures by case name from a figures.json, a folder of runs (every figures.json
    under it), or a results.json of an earlier report."""
    if path.is_dir():
        files = sorted(path.rglob("figures.json"))
        if not files:
            raise VehilError(f"{path}: no figures.json under it to compare with")
        return {c.name: c.figures for c in (case_from_folder(f.parent) for f in files)}
    try:
        data = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise VehilError(f"{path}: not a baseline figures.json ({exc})") from None
    if isinstance(data, dict) and "cases" in data:
        return {c["name"]: c["figures"] for c in data["cases"]}
    if isinstance(data, dict) and "verdict" in data:
        return {str(data.get("scenario", "")): data}
    raise VehilError(
        f"{path}: neither a run's figures.json nor a report's results.json: "
        "give one of those, or a folder of runs"
    )


def trend(case: Case, baseline: dict[str, dict[str, Any]]) -> list[tuple[str, float, float]]:
    """(figure, baseline, now) for the figures that trend (errors, cycles), where both
    have them."""
    before = baseline.get(case.name)
    if before is None:
        return []
    a, b = flat(before), flat(case.figures)
    keys = [k for k in b if k.endswith(TREND_KEYS) or k in ("cycles.median", "cycles.max")]
    return [(k, float(a[k]), float(b[k])) for k in keys if k in a and not isinstance(a[k], str)]


def write_json(cases: Sequence[Case], title: str, path: Path) -> Path:
    """results.json: every case's figures (a later report's baseline)."""
    data = {
        "title": title,
        "verdicts": _verdicts(cases),
        "cases": [{"name": c.name, "figures": c.figures} for c in cases],
    }
    path.write_text(json.dumps(data, indent=1, default=str))
    return path


_CSS = """
body { font: 14px/1.4 system-ui, sans-serif; margin: 1.5em; color: #222; }
table { border-collapse: collapse; margin: 0.6em 0; }
th, td { border: 1px solid #ccc; padding: 3px 8px; text-align: left; vertical-align: top; }
th { background: #f0f0f0; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
.PASS { color: #16702e; font-weight: bold; }
.FAIL, .FAILED, .INTERRUPTED { color: #b3261e; font-weight: bold; }
.NOT-CHECKED { color: #946200; font-weight: bold; }
.worse { color: #b3261e; } .better { color: #16702e; }
img.plot { max-width: 100%; border: 1px solid #ddd; margin: 0.4em 0; }
details { margin: 0.5em 0; } summary { cursor: pointer; }
"""


def _e(x: Any) -> str:
    return html.escape(str(x))


def _num(x: float) -> str:
    if isinstance(x, bool):
        return str(x)
    if isinstance(x, int):
        return f"{x:,}"
    return "nan" if math.isnan(x) else f"{x:.4g}"


def _word_class(word: str) -> str:
    return word.replace(" ", "-")


def _img(png: Path, alt: str) -> str:
    data = base64.b64encode(png.read_bytes()).decode("ascii")
    return f'<img class="plot" alt="{_e(alt)}" src="data:image/png;base64,{data}">'


def _plots(folder: Path | None) -> Iterator[str]:
    if folder is not None:
        for png in sorted(folder.glob("*.png")):
            yield _img(png, f"{folder.name}: {png.stem}")


def _change(a: float, b: float) -> str:
    if a == b:
        return "="
    if a == 0:
        return "new"
    pct = (b - a) / abs(a) * 100
    # Errors and cycles: lower is better.
    return f'<span class="{"worse" if b > a else "better"}">{pct:+.1f} %</span>'


def write_html(
    cases: Sequence[Case],
    title: str,
    path: Path,
    baseline: dict[str, dict[str, Any]] | None = None,
    images: Sequence[Path] = (),
) -> Path:
    """One HTML file that needs nothing else: every image is embedded."""
    words = _verdicts(cases)
    out = [
        "<!doctype html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{_e(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{_e(title)}</h1>",
        f"<p>{len(cases)} runs: "
        + ", ".join(f'<span class="{_word_class(w)}">{_e(w)}</span> {n}' for w, n in words.items())
        + f"; written {datetime.now(UTC).isoformat(timespec='seconds')}</p>",
        *(_img(p, p.stem) for p in images),
        '<h2>Verdicts</h2><table id="verdicts"><thead><tr><th>run</th><th>verdict</th>'
        "<th>why</th><th>samples</th><th>cycles median</th><th>wall s</th></tr></thead><tbody>",
    ]
    for i, c in enumerate(cases):
        f = c.figures
        cycles = (f.get("cycles") or {}).get("median")
        out.append(
            f'<tr><td><a href="#run-{i}">{_e(c.name)}</a></td>'
            f'<td class="{_word_class(c.word)}">{_e(c.word)}</td><td>{_e(c.reason)}</td>'
            f'<td class="num">{_num(f["samples"]) if f.get("samples") is not None else ""}</td>'
            f'<td class="num">{_num(cycles) if cycles is not None else ""}</td>'
            f'<td class="num">{_num(f["wall_s"]) if f.get("wall_s") is not None else ""}</td></tr>'
        )
    out.append("</tbody></table>")
    if baseline is not None:
        out += [
            '<h2>Trend against the baseline</h2><table id="trend"><thead><tr><th>run</th>'
            "<th>figure</th><th>baseline</th><th>now</th><th>change</th></tr></thead><tbody>"
        ]
        for c in cases:
            for k, a, b in trend(c, baseline):
                out.append(
                    f"<tr><td>{_e(c.name)}</td><td>{_e(k)}</td><td class='num'>{_num(a)}</td>"
                    f"<td class='num'>{_num(b)}</td><td class='num'>{_change(a, b)}</td></tr>"
                )
            if c.name in baseline and baseline[c.name].get("verdict", {}).get("word") != c.word:
                was = baseline[c.name].get("verdict", {}).get("word")
                out.append(
                    f"<tr><td>{_e(c.name)}</td><td>verdict</td><td>{_e(was)}</td>"
                    f"<td>{_e(c.word)}</td><td class='worse'>changed</td></tr>"
                )
        missing = [c.name for c in cases if c.name not in baseline]
        out.append("</tbody></table>")
        if missing:
            out.append(f"<p>Not in the baseline: {_e(', '.join(missing))}</p>")
    out.append("<h2>Runs</h2>")
    for i, c in enumerate(cases):
        out += [
            f'<details id="run-{i}" open><summary><b>{_e(c.name)}</b>: '
            f'<span class="{_word_class(c.word)}">{_e(c.word)}</span> {_e(c.reason)}</summary>',
            "<table><tbody>",
            *(f"<tr><th>{_e(k)}</th><td>{_e(v)}</td></tr>" for k, v in _context(c.figures).items()),
            *(
                f"<tr><th>{_e(k)}</th><td class='num'>{_num(v) if not isinstance(v, str) else v}"
                "</td></tr>"
                for k, v in flat(c.figures).items()
            ),
            "</tbody></table>",
            *_plots(c.folder),
            "</details>",
        ]
    out.append("</body></html>")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(out), encoding="utf-8")
    return path
