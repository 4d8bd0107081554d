"""Scenario files: what to run, on what data, against which tolerances.

A scenario is a TOML file (see scenarios/ and the README). Loading checks every
key, unit and range, and names the file, the key and what is allowed, so a typo
fails before a board is started.
"""

from __future__ import annotations

import difflib
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vehil import estimators, plants, project
from vehil.csvlog import DELIMITERS
from vehil.errors import VehilError
from vehil.estimators.base import MODES, EstimatorSpec
from vehil.paths import DATA_ROOT
from vehil.perturb import Perturbation, declare
from vehil.protocol.schema import SCHEMA

SCENARIO_DIR = DATA_ROOT / "scenarios"
LOG_FORMATS = ("csv", "mdf4", "vehil", "blf", "asc", "candump")
LOG_SUFFIXES = {
    ".csv": "csv",
    ".mf4": "mdf4",
    ".mdf": "mdf4",
    ".arrow": "vehil",
    ".blf": "blf",
    ".asc": "asc",
    ".log": "candump",
}
# Exports that need only their column map: the time column, its text format, a units row.
LOG_PRESETS: dict[str, dict[str, Any]] = {
    "torque": {"format": "csv", "time": "Device Time", "time_format": "%d-%b-%Y %H:%M:%S.%f"},
    "asammdf": {"format": "csv", "time": "timestamps", "units_row": True},
}


class ScenarioError(VehilError):
    """A scenario file is wrong: the message names the file, the key and what is allowed."""


@dataclass(frozen=True)
class Tolerance:
    """Board vs float64 reference: |board - ref| <= abs + rel * |ref| at every sample from
    time `from_s` and sample `from_samples` on (before it an output may be unobservable, and
    its digits noise). `from_samples` is for a start-up counted in samples, whatever the
    sample time: a window that fills, a prior corrected step by step."""

    abs: float = 0.0
    rel: float = 0.0
    from_s: float = 0.0
    from_samples: int = 0
    bit_exact: bool = False  # FIXED: the board's bits equal the native build's
    truth_rms: float | None = None  # RMS error vs truth must stay below this


@dataclass(frozen=True)
class ColumnMap:
    """Where one estimator input (or truth) comes from in a log: a column (its unit
    stated, scaled and offset: value = raw * scale + offset in that unit), the filtered
    time derivative of a column, a column divided by a wheel radius, or a constant."""

    column: str | None = None
    unit: str | None = None  # the scenario's word on the column's unit, over the log's
    scale: float = 1.0
    offset: float = 0.0
    derivative: bool = False  # d/dt of the column, low-passed at cutoff_hz
    cutoff_hz: float = 2.0
    radius: float | None = None  # m: a speed over a wheel radius gives a wheel speed
    value: float | None = None  # a constant, in `unit` or the input's unit

    @classmethod
    def of(cls, spec: str | ColumnMap) -> ColumnMap:
        if isinstance(spec, ColumnMap):
            return spec
        if spec.startswith("d/dt "):
            return cls(column=spec[5:].strip(), derivative=True)
        return cls(column=spec)


@dataclass(frozen=True)
class LogSource:
    path: Path
    format: str
    time: str
    columns: dict[str, str | ColumnMap]  # estimator input -> column
    truth: dict[str, str | ColumnMap]  # estimator output -> column
    dbc: Path | None = None  # raw CAN: signals are MESSAGE.SIGNAL of this DBC
    time_format: str | None = None  # strptime codes of text time stamps
    time_unit: str | None = None  # the time column's unit, where its header has none
    units_row: bool | None = None  # a row of units under the header; None: found as such
    delimiter: str | None = None  # a CSV's field separator; None: the one its header has
    decimal: str | None = None  # a CSV's decimal sign; None: the one its numbers have
    max_gap_s: float | None = None  # None: 5 of a channel's median steps
    on_gap: str = "refuse"  # or "split": run the longest stretch without a gap


@dataclass(frozen=True)
class Scenario:
    name: str
    path: Path | None
    title: str
    duration: float
    sample_time: float
    seed: int
    estimator: EstimatorSpec
    mode: str
    params: dict[str, float]
    plant: str | None = None
    plant_params: dict[str, Any] = field(default_factory=dict)  # numbers, and tables read
    log: LogSource | None = None
    closed_loop: bool = False  # the plant applies the board's outputs each sample
    signals: dict[str, str] = field(default_factory=dict)  # estimator input -> source signal
    tolerances: dict[str, Tolerance] = field(default_factory=dict)
    paper: str = ""
    figures: tuple[str, ...] = ()
    # Truth metrics count from this time on: the convergence from the initial guess is
    # the estimator's start-up, not its accuracy.
    score_from_s: float = 0.0
    # Status flags the drive was built to raise (a health check's test): each must fire,
    # and DIVERGED listed here does not fail the run.
    expect_flags: tuple[str, ...] = ()
    sweep: dict[str, Perturbation] = field(default_factory=dict)  # [sweep]: `vehil sweep`'s
    raw: dict[str, Any] = field(default_factory=dict)  # the file as parsed, for the recording

    @property
    def samples(self) -> int:
        return int(round(self.duration / self.sample_time))


class _Checker:
    """Reads one table of the file, remembering where it is for error messages."""

    def __init__(self, where: str, table: Any, section: str):
        self.where = where
        self.section = section
        if not isinstance(table, dict):
            raise ScenarioError(f"{where}: [{section}] must be a table")
        self.table = table

    def fail(self, key: str, what: str) -> ScenarioError:
        dotted = ".".join(part for part in (self.section, key) if part)
        return ScenarioError(f"{self.where}: {dotted}: {what}")

    def only(self, *allowed: str) -> None:
        for key in self.table:
            if key not in allowed:
                raise self.fail(key, f"unknown key; allowed here: {', '.join(allowed)}")

    def number(
        self, key: str, default: float | None = None, lo: float = -math.inf, hi: float = math.inf
    ) -> float:
        value = self.table.get(key, default)
        if value is None:
            raise self.fail(key, "missing; it is required")
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(key, f"must be a number, got {value!r}")
        if not (math.isfinite(value) and lo <= value <= hi):
            raise self.fail(key, f"{value!r} is outside [{lo:g}, {hi:g}]")
        return float(value)

    def count(self, key: str) -> int:
        """A whole number of samples, 0 when not given."""
        value = self.table.get(key, 0)
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise self.fail(key, f"must be a whole number of samples (0 or more), got {value!r}")
        return value

    def text(self, key: str, default: str | None = None, choices: tuple[str, ...] = ()) -> str:
        value = self.table.get(key, default)
        if value is None:
            raise self.fail(key, "missing; it is required")
        if not isinstance(value, str):
            raise self.fail(key, f"must be a string, got {value!r}")
        if choices and value not in choices:
            raise self.fail(key, f"{value!r} is not one of {', '.join(choices)}")
        return value

    def sub(self, key: str) -> _Checker:
        return _Checker(self.where, self.table.get(key, {}), f"{self.section}.{key}".strip("."))

    def columns(self, key: str, allowed: tuple[str, ...], what: str) -> dict[str, str | ColumnMap]:
        """[log.columns] and [log.truth]: a column name, "d/dt NAME", a number (a
        constant), or a table of column, unit, scale, offset, derivative, cutoff_hz,
        radius, value."""
        table = self.sub(key)
        out: dict[str, str | ColumnMap] = {}
        for name, value in table.table.items():
            if name not in allowed:
                raise table.fail(name, f"no {what} of that name; known: {', '.join(allowed)}")
            if isinstance(value, str):
                out[name] = value
            elif isinstance(value, int | float) and not isinstance(value, bool):
                out[name] = ColumnMap(value=float(value))
            elif isinstance(value, dict):
                c = table.sub(name)
                c.only(
                    "column",
                    "unit",
                    "scale",
                    "offset",
                    "derivative",
                    "cutoff_hz",
                    "radius",
                    "value",
                )
                if ("column" in c.table) == ("value" in c.table):
                    raise c.fail("", "give exactly one of column and value")
                derivative = c.table.get("derivative", False)
                if not isinstance(derivative, bool):
                    raise c.fail("derivative", f"must be true or false, got {derivative!r}")
                out[name] = ColumnMap(
                    column=c.text("column") if "column" in c.table else None,
                    unit=c.text("unit") if "unit" in c.table else None,
                    scale=c.number("scale", 1.0),
                    offset=c.number("offset", 0.0),
                    derivative=derivative,
                    cutoff_hz=c.number("cutoff_hz", 2.0, lo=1e-3),
                    radius=c.number("radius", lo=1e-3, hi=10.0) if "radius" in c.table else None,
                    value=c.number("value") if "value" in c.table else None,
                )
            else:
                raise table.fail(
                    name, f'must be a column name, "d/dt NAME", a number or a table; got {value!r}'
                )
        return out

    def mapping(self, key: str, allowed: tuple[str, ...], what: str) -> dict[str, str]:
        table = self.sub(key)
        for name, value in table.table.items():
            if name not in allowed:
                raise table.fail(name, f"no {what} of that name; known: {', '.join(allowed)}")
            if not isinstance(value, str):
                raise table.fail(name, f"must be a column or signal name, got {value!r}")
        return dict(table.table)


def _seed(sc: _Checker) -> int:
    """The noise seed: a whole number (1.5 would be cut to 1, the drive of another seed)."""
    seed = sc.number("seed", 0, lo=0, hi=2**32 - 1)
    if seed != int(seed):
        raise sc.fail("seed", f"must be a whole number, got {seed:g}")
    return int(seed)


def _numbers(table: _Checker) -> dict[str, float]:
    return {k: table.number(k) for k in table.table}


def _log_source(
    lg: _Checker, path: Path | None, inputs: tuple[str, ...], outputs: tuple[str, ...]
) -> LogSource:
    lg.only(
        "path",
        "format",
        "preset",
        "time",
        "time_format",
        "time_unit",
        "units_row",
        "delimiter",
        "decimal",
        "dbc",
        "max_gap_s",
        "on_gap",
        "columns",
        "truth",
    )
    base = path.parent if path else Path.cwd()
    log_path = (base / lg.text("path")).resolve()
    preset: dict[str, Any] = {}
    if "preset" in lg.table:
        preset = LOG_PRESETS[lg.text("preset", choices=tuple(LOG_PRESETS))]
    fmt = lg.text(
        "format",
        preset.get("format") or LOG_SUFFIXES.get(log_path.suffix.lower(), "csv"),
        choices=LOG_FORMATS,
    )
    dbc = (base / lg.text("dbc")).resolve() if "dbc" in lg.table else None
    if fmt in ("blf", "asc", "candump") and dbc is None:
        raise lg.fail("dbc", f"a {fmt} log holds raw CAN frames: name the DBC that decodes them")
    units_row = lg.table.get("units_row", preset.get("units_row"))
    if not isinstance(units_row, bool | None):
        raise lg.fail("units_row", f"must be true or false, got {units_row!r}")
    return LogSource(
        path=log_path,
        format=fmt,
        time=lg.text("time", preset.get("time", "t")),
        columns=lg.columns("columns", inputs, "estimator input"),
        truth=lg.columns("truth", outputs, "estimator output"),
        dbc=dbc,
        time_format=lg.text("time_format")
        if "time_format" in lg.table
        else preset.get("time_format"),
        time_unit=lg.text("time_unit") if "time_unit" in lg.table else None,
        units_row=units_row,
        delimiter=lg.text("delimiter", choices=DELIMITERS) if "delimiter" in lg.table else None,
        decimal=lg.text("decimal", choices=(".", ",")) if "decimal" in lg.table else None,
        max_gap_s=lg.number("max_gap_s", lo=1e-6) if "max_gap_s" in lg.table else None,
        on_gap=lg.text("on_gap", "refuse", choices=("refuse", "split")),
    )


def _sweep(
    top: _Checker, plant: plants.PlantSpec, nominal: dict[str, Any]
) -> dict[str, Perturbation]:
    table = top.sub("sweep")
    try:
        return {
            name: declare(name, value, plant.params, nominal, plant.name)
            for name, value in table.table.items()
        }
    except ValueError as exc:
        raise ScenarioError(f"{table.where}: {exc}") from None


def _own_step(sc: _Checker, top: _Checker, path: Path | None, spec: EstimatorSpec) -> float:
    """sample_time = "log": the log's own regular step (its time-step parameters follow)."""
    from vehil.logs import own_step  # the log is read here: only this setting needs it

    if "log" not in top.table:
        raise sc.fail("sample_time", '"log" takes the step of a [log]; a plant needs seconds')
    inputs = tuple(s.name for s in spec.inputs)
    outputs = tuple(s.name for s in spec.outputs)
    try:
        return own_step(_log_source(top.sub("log"), path, inputs, outputs), spec)
    except VehilError as exc:
        raise sc.fail("sample_time", f'"log": {exc}') from None


def parse(data: dict[str, Any], where: str, path: Path | None = None) -> Scenario:
    top = _Checker(where, data, "")
    top.only("scenario", "plant", "log", "estimator", "signals", "tolerance", "sweep")
    sc = top.sub("scenario")
    sc.only(
        "name",
        "title",
        "duration",
        "sample_time",
        "seed",
        "paper",
        "figures",
        "closed_loop",
        "score_from_s",
        "expect_flags",
    )
    est_t = top.sub("estimator")
    est_t.only("name", "mode", "params")
    known = estimators.estimators()
    spec = known.get(est_t.text("name"))
    if spec is None:
        raise est_t.fail("name", f"no such estimator; known: {', '.join(sorted(known))}")
    mode = est_t.text("mode", "F32", choices=MODES)
    if mode not in spec.modes:
        raise est_t.fail("mode", f"{spec.name} runs in {', '.join(spec.modes)} only")
    inputs = tuple(s.name for s in spec.inputs)
    outputs = tuple(s.name for s in spec.outputs)
    if sc.table.get("sample_time") == "log":
        sample_time = _own_step(sc, top, path, spec)
    else:
        sample_time = sc.number("sample_time", lo=1e-5, hi=10.0)
    given = _numbers(est_t.sub("params"))
    if "T" in {p.name for p in spec.params}:
        given.setdefault("T", sample_time)
    try:
        params = spec.param_values(given)
    except ValueError as exc:
        raise est_t.fail("params", str(exc)) from None
    if problems := spec.rule_problems(params, mode):
        raise est_t.fail("params", f"{spec.name} in {mode}: {'; '.join(problems)}")

    if ("plant" in data) == ("log" in data):
        raise ScenarioError(f"{where}: give exactly one of [plant] and [log]")
    plant_name, log = None, None
    plant_params: dict[str, Any] = {}
    if "plant" in data:
        pl = top.sub("plant")
        plant_name = pl.text("name")
        known_plants = plants.plants()
        if plant_name not in known_plants:
            raise pl.fail("name", f"no such plant; known: {', '.join(sorted(known_plants))}")
        file_inputs = {f.name for f in known_plants[plant_name].files}
        rest = _Checker(
            where, {k: v for k, v in pl.table.items() if k not in file_inputs | {"name"}}, "plant"
        )
        plant_given: dict[str, Any] = dict(_numbers(rest))
        for name in file_inputs & pl.table.keys():
            # A table file, relative to the scenario's folder.
            plant_given[name] = (path.parent if path else Path()) / pl.text(name)
        try:
            plant_params = known_plants[plant_name].param_values(plant_given)
        except ValueError as exc:
            raise rest.fail("", str(exc)) from None
        except VehilError as exc:  # a table file that cannot be used
            raise ScenarioError(f"{where}: [plant]: {exc}") from None
        duration = sc.number("duration", lo=sample_time, hi=86_400.0)
        closed_loop = sc.table.get("closed_loop", False)
        if not isinstance(closed_loop, bool):
            raise sc.fail("closed_loop", f"must be true or false, got {closed_loop!r}")
        plant_spec = known_plants[plant_name]
        if closed_loop:
            if plant_spec.loop is None:
                raise sc.fail("closed_loop", f"plant {plant_name} runs open loop only")
            missing = [f for f in plant_spec.feedback if f not in outputs]
            if missing:
                raise sc.fail(
                    "closed_loop",
                    f"plant {plant_name} needs {', '.join(missing)} from the estimator, "
                    f"which gives {', '.join(outputs)}",
                )
        sweep = _sweep(top, plant_spec, plant_params)
    else:
        if "sweep" in data:
            raise ScenarioError(f"{where}: [sweep] varies a plant; a recorded drive has none")
        sweep = {}
        if sc.table.get("closed_loop"):
            raise sc.fail("closed_loop", "a recorded drive cannot close a loop")
        closed_loop = False
        log = _log_source(top.sub("log"), path, inputs, outputs)
        # A log runs to its end unless the scenario cuts it shorter.
        duration = sc.number("duration", lo=sample_time) if "duration" in sc.table else math.inf
    signals = top.mapping("signals", inputs, "estimator input")
    if plant_name is not None:  # each input from a signal the plant measures
        gives = [g.name for g in known_plants[plant_name].signals]
        for name in inputs:
            if signals.get(name, name) not in gives:
                mapped = f"signals.{name} = {signals[name]!r}" if name in signals else "input"
                raise ScenarioError(
                    f"{where}: {mapped}: plant {plant_name} measures no such signal; it gives "
                    f"{', '.join(gives)}: map {spec.name}'s {name} to one in [signals]"
                )

    tol_t = top.sub("tolerance")
    tolerances = {}
    for name in tol_t.table:
        if name not in outputs:
            raise tol_t.fail(name, f"no output of that name; {spec.name} has {', '.join(outputs)}")
        t = tol_t.sub(name)
        t.only("abs", "rel", "from_s", "from_samples", "bit_exact", "truth_rms")
        bit_exact = t.table.get("bit_exact", False)
        if not isinstance(bit_exact, bool):
            raise t.fail("bit_exact", f"must be true or false, got {bit_exact!r}")
        tolerances[name] = Tolerance(
            abs=t.number("abs", 0.0, lo=0.0),
            rel=t.number("rel", 0.0, lo=0.0),
            from_s=t.number("from_s", 0.0, lo=0.0),
            from_samples=t.count("from_samples"),
            bit_exact=bit_exact,
            truth_rms=t.number("truth_rms", lo=0.0) if "truth_rms" in t.table else None,
        )
        start = max(tolerances[name].from_s, tolerances[name].from_samples * sample_time)
        if start >= duration:
            raise t.fail(
                "from_s" if "from_s" in t.table else "from_samples",
                f"starts at {start:g} s, where the drive has ended ({duration:g} s): "
                "nothing would be checked",
            )
    score_from_s = sc.number("score_from_s", 0.0, lo=0.0)
    if score_from_s >= duration:
        raise sc.fail(
            "score_from_s",
            f"{score_from_s:g} s leaves nothing to score: the drive lasts {duration:g} s",
        )
    figures = sc.table.get("figures", [])
    if not isinstance(figures, list) or not all(isinstance(f, str) for f in figures):
        raise sc.fail("figures", "must be a list of strings")
    expect_flags = sc.table.get("expect_flags", [])
    if not isinstance(expect_flags, list) or not all(f in SCHEMA.status for f in expect_flags):
        names = ", ".join(sorted(SCHEMA.status))
        raise sc.fail("expect_flags", f"must be a list of status flags from {names}")
    return Scenario(
        name=sc.text("name", path.stem if path else "scenario"),
        path=path,
        title=sc.text("title", ""),
        duration=duration,
        sample_time=sample_time,
        seed=_seed(sc),
        estimator=spec,
        mode=mode,
        params=params,
        plant=plant_name,
        plant_params=plant_params,
        log=log,
        closed_loop=closed_loop,
        signals=signals,
        tolerances=tolerances,
        paper=sc.text("paper", ""),
        figures=tuple(figures),
        score_from_s=score_from_s,
        expect_flags=tuple(expect_flags),
        sweep=sweep,
        raw=data,
    )


def scenario_dirs() -> tuple[Path, ...]:
    """Where scenarios are found by name: the project's folder (vehil.toml), then vehil's."""
    here = project.current()
    return (here.scenarios, SCENARIO_DIR) if here and here.scenarios else (SCENARIO_DIR,)


def scenario_name(path: Path) -> str:
    """NAME as `vehil run NAME` finds it: the path under its scenario folder."""
    for folder in scenario_dirs():
        if path.resolve().is_relative_to(folder.resolve()):
            return str(path.resolve().relative_to(folder.resolve()).with_suffix(""))
    return str(path)


def find(name_or_path: str | Path) -> Path:
    """A scenario by path, or by name among the project's and the shipped ones
    (scenarios/**/NAME.toml); the project's first."""
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.exists():
        if not path.exists():
            raise ScenarioError(f"{path}: no such scenario file")
        return path
    for folder in scenario_dirs():
        matches = sorted(folder.rglob(f"{name_or_path}.toml"))
        if len(matches) == 1:
            return matches[0]
        if matches:
            listed = ", ".join(str(m.relative_to(folder)) for m in matches)
            raise ScenarioError(f"{name_or_path!r} is ambiguous: {listed}; give the path")
    names = {scenario_name(p): p for p in shipped()}
    by_stem = {p.stem: name for name, p in names.items()}
    close = difflib.get_close_matches(str(name_or_path), [*names, *by_stem], n=3)
    like = list(dict.fromkeys(by_stem.get(c, c) for c in close))
    hint = f" (did you mean {', '.join(like)}?)" if like else ""
    raise ScenarioError(
        f"no scenario {name_or_path!r}{hint}: give a .toml path or a name from `vehil scenarios`"
    )


def load(name_or_path: str | Path) -> Scenario:
    path = find(name_or_path)
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}") from None
    return parse(data, str(path), path.resolve())


def shipped() -> list[Path]:
    """Every scenario found by name: the project's, then vehil's."""
    return [p for folder in scenario_dirs() for p in sorted(folder.rglob("*.toml"))]
