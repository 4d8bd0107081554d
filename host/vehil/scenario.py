"""Scenario files: what to run, on what data, against which tolerances.

A scenario is a TOML file (see scenarios/ and the README). Loading checks every
key, unit and range, and names the file, the key and what is allowed, so a typo
fails before a board is started.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vehil import estimators, plants
from vehil.errors import VehilError
from vehil.estimators.base import MODES, EstimatorSpec
from vehil.paths import PROJECT_ROOT

SCENARIO_DIR = PROJECT_ROOT / "scenarios"
LOG_FORMATS = ("csv", "mdf4", "vehil")


class ScenarioError(VehilError):
    """A scenario file is wrong: the message names the file, the key and what is allowed."""


@dataclass(frozen=True)
class Tolerance:
    """Board vs float64 reference: |board - ref| <= abs + rel * |ref| at every sample from
    time `from_s` on (before it an output may be unobservable, and its digits noise)."""

    abs: float = 0.0
    rel: float = 0.0
    from_s: float = 0.0
    bit_exact: bool = False  # FIXED: the board's bits equal the native build's
    truth_rms: float | None = None  # RMS error vs truth must stay below this


@dataclass(frozen=True)
class LogSource:
    path: Path
    format: str
    time: str
    columns: dict[str, str]  # estimator input -> column
    truth: dict[str, str]  # estimator output -> column


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

    def mapping(self, key: str, allowed: tuple[str, ...], what: str) -> dict[str, str]:
        table = self.sub(key)
        for name, value in table.table.items():
            if name not in allowed:
                raise table.fail(name, f"no {what} of that name; known: {', '.join(allowed)}")
            if not isinstance(value, str):
                raise table.fail(name, f"must be a column or signal name, got {value!r}")
        return dict(table.table)


def _numbers(table: _Checker) -> dict[str, float]:
    return {k: table.number(k) for k in table.table}


def parse(data: dict[str, Any], where: str, path: Path | None = None) -> Scenario:
    top = _Checker(where, data, "")
    top.only("scenario", "plant", "log", "estimator", "signals", "tolerance")
    sc = top.sub("scenario")
    sc.only("name", "title", "duration", "sample_time", "seed", "paper", "figures", "closed_loop")
    sample_time = sc.number("sample_time", lo=1e-5, hi=10.0)
    est_t = top.sub("estimator")
    est_t.only("name", "mode", "params")
    known = estimators.estimators()
    spec = known.get(est_t.text("name"))
    if spec is None:
        raise est_t.fail("name", f"no such estimator; known: {', '.join(sorted(known))}")
    mode = est_t.text("mode", "F32", choices=MODES)
    if mode not in spec.modes:
        raise est_t.fail("mode", f"{spec.name} runs in {', '.join(spec.modes)} only")
    given = _numbers(est_t.sub("params"))
    if "T" in {p.name for p in spec.params}:
        given.setdefault("T", sample_time)
    try:
        params = spec.param_values(given)
    except ValueError as exc:
        raise est_t.fail("params", str(exc)) from None

    if ("plant" in data) == ("log" in data):
        raise ScenarioError(f"{where}: give exactly one of [plant] and [log]")
    inputs = tuple(s.name for s in spec.inputs)
    outputs = tuple(s.name for s in spec.outputs)
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
    else:
        if sc.table.get("closed_loop"):
            raise sc.fail("closed_loop", "a recorded drive cannot close a loop")
        closed_loop = False
        lg = top.sub("log")
        lg.only("path", "format", "time", "columns", "truth")
        base = path.parent if path else Path.cwd()
        log = LogSource(
            path=(base / lg.text("path")).resolve(),
            format=lg.text("format", "csv", choices=LOG_FORMATS),
            time=lg.text("time", "t"),
            columns=lg.mapping("columns", inputs, "estimator input"),
            truth=lg.mapping("truth", outputs, "estimator output"),
        )
        # A log runs to its end unless the scenario cuts it shorter.
        duration = sc.number("duration", lo=sample_time) if "duration" in sc.table else math.inf
    signals = top.mapping("signals", inputs, "estimator input")

    tol_t = top.sub("tolerance")
    tolerances = {}
    for name in tol_t.table:
        if name not in outputs:
            raise tol_t.fail(name, f"no output of that name; {spec.name} has {', '.join(outputs)}")
        t = tol_t.sub(name)
        t.only("abs", "rel", "from_s", "bit_exact", "truth_rms")
        bit_exact = t.table.get("bit_exact", False)
        if not isinstance(bit_exact, bool):
            raise t.fail("bit_exact", f"must be true or false, got {bit_exact!r}")
        tolerances[name] = Tolerance(
            abs=t.number("abs", 0.0, lo=0.0),
            rel=t.number("rel", 0.0, lo=0.0),
            from_s=t.number("from_s", 0.0, lo=0.0),
            bit_exact=bit_exact,
            truth_rms=t.number("truth_rms", lo=0.0) if "truth_rms" in t.table else None,
        )
    figures = sc.table.get("figures", [])
    if not isinstance(figures, list) or not all(isinstance(f, str) for f in figures):
        raise sc.fail("figures", "must be a list of strings")
    return Scenario(
        name=sc.text("name", path.stem if path else "scenario"),
        path=path,
        title=sc.text("title", ""),
        duration=duration,
        sample_time=sample_time,
        seed=int(sc.number("seed", 0, lo=0, hi=2**32 - 1)),
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
        raw=data,
    )


def find(name_or_path: str | Path) -> Path:
    """A scenario by path, or by name among the shipped ones (scenarios/**/NAME.toml)."""
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.exists():
        if not path.exists():
            raise ScenarioError(f"{path}: no such scenario file")
        return path
    matches = sorted(SCENARIO_DIR.rglob(f"{name_or_path}.toml"))
    if len(matches) == 1:
        return matches[0]
    if matches:
        listed = ", ".join(str(m.relative_to(SCENARIO_DIR)) for m in matches)
        raise ScenarioError(f"{name_or_path!r} is ambiguous: {listed}; give the path")
    raise ScenarioError(
        f"no scenario {name_or_path!r}: give a .toml path or a name from `vehil scenarios`"
    )


def load(name_or_path: str | Path) -> Scenario:
    path = find(name_or_path)
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}") from None
    return parse(data, str(path), path.resolve())


def shipped() -> list[Path]:
    return sorted(SCENARIO_DIR.rglob("*.toml"))
