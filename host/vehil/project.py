"""A user's project: a `vehil.toml` at its root names the Python specs of its own
estimators and plants and the folder of its scenarios, so vehil finds them without
their living in vehil's package (docs/extending.md):

    [project]
    name = "my-filters"
    estimators = ["specs/comp_speed.py"]   # modules that register EstimatorSpecs
    plants = ["plants/*.py"]               # modules that register PlantSpecs (globs)
    scenarios = "scenarios"                # scenarios/**/NAME.toml, found by name
    c_sources = ["c"]                      # folders of the estimators' C: NAME.h and NAME.c
    image = "comp_speed"                   # the estimators in the project's image

The project is the nearest vehil.toml from the current directory up, or the one
$VEHIL_PROJECT names. Packaged specs are found through the entry points
`vehil.estimators` and `vehil.plants` instead (vehil/registry.py).
"""

from __future__ import annotations

import functools
import importlib.util
import os
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vehil.errors import VehilError

FILE_NAME = "vehil.toml"
_KEYS = {"name", "estimators", "plants", "scenarios", "c_sources", "image"}


class ProjectError(VehilError):
    """vehil.toml is wrong: the message names the file and the key."""


@dataclass(frozen=True)
class Project:
    root: Path
    name: str
    estimators: tuple[Path, ...]
    plants: tuple[Path, ...]
    scenarios: Path | None
    c_sources: tuple[Path, ...] = ()  # folders: every *.c compiled, *.h on the include path
    image: str | None = None  # vehil/build/registry.py's words; None: the project's own C

    def modules(self, kind: str) -> tuple[Path, ...]:
        return self.estimators if kind == "estimator" else self.plants


def _paths(root: Path, where: str, key: str, value: Any) -> tuple[Path, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ProjectError(f"{where}: project.{key}: a list of paths or globs, got {value!r}")
    found: list[Path] = []
    for pattern in value:
        matches = sorted(root.glob(pattern))
        if not matches and not any(c in pattern for c in "*?["):  # a glob may match none yet
            raise ProjectError(f"{where}: project.{key}: no file {root / pattern}")
        bad = [m for m in matches if m.suffix != ".py"]
        if bad:
            raise ProjectError(f"{where}: project.{key}: {bad[0]} is not a Python module")
        found += matches
    return tuple(found)


def _folders(root: Path, where: str, value: Any) -> tuple[Path, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ProjectError(f"{where}: project.c_sources: a list of folders, got {value!r}")
    missing = [v for v in value if not (root / v).is_dir()]
    if missing:
        raise ProjectError(f"{where}: project.c_sources: no folder {root / missing[0]}")
    folders = tuple((root / v).resolve() for v in value)
    spaced = [f for f in folders if any(c.isspace() for c in str(f))]
    if spaced:  # PlatformIO's options are lists split at white space
        raise ProjectError(
            f"{where}: project.c_sources: {spaced[0]} has white space in its path, which "
            "the AVR build cannot take: move the project to a path without"
        )
    return folders


def parse(path: Path) -> Project:
    where = str(path)
    try:
        raw = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ProjectError(f"{where}: not valid TOML: {exc}") from None
    table = raw.get("project")
    if not isinstance(table, dict) or set(raw) != {"project"}:
        raise ProjectError(f"{where}: give one [project] table (see docs/extending.md)")
    unknown = sorted(set(table) - _KEYS)
    if unknown:
        raise ProjectError(
            f"{where}: project.{unknown[0]}: unknown key; allowed: {', '.join(sorted(_KEYS))}"
        )
    root = path.parent.resolve()
    scenarios = table.get("scenarios")
    if scenarios is not None and not (root / str(scenarios)).is_dir():
        raise ProjectError(f"{where}: project.scenarios: no folder {root / str(scenarios)}")
    return Project(
        root=root,
        name=str(table.get("name", root.name)),
        estimators=_paths(root, where, "estimators", table.get("estimators", [])),
        plants=_paths(root, where, "plants", table.get("plants", [])),
        scenarios=root / str(scenarios) if scenarios is not None else None,
        c_sources=_folders(root, where, table.get("c_sources", [])),
        image=_image(where, table.get("image")),
    )


def _image(where: str, value: Any) -> str | None:
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, list) and all(isinstance(v, str) for v in value):
        return " ".join(value)
    raise ProjectError(
        f"{where}: project.image: estimator names (a list, or `all -name`), got {value!r}"
    )


def find_file(start: Path | None = None) -> Path | None:
    named = os.environ.get("VEHIL_PROJECT")
    if named:
        path = Path(named)
        path = path / FILE_NAME if path.is_dir() else path
        if not path.is_file():
            raise ProjectError(f"$VEHIL_PROJECT names {named}, which has no {FILE_NAME}")
        return path
    here = (start or Path.cwd()).resolve()
    for folder in (here, *here.parents):
        if (folder / FILE_NAME).is_file():
            return folder / FILE_NAME
    return None


@functools.cache
def current() -> Project | None:
    """The project vehil runs in, if any (read once per process)."""
    path = find_file()
    return parse(path) if path is not None else None


def import_module(path: Path, kind: str) -> None:
    """Runs a project's spec module (it registers its specs); errors name the file."""
    name = f"vehil_project_{kind}s.{path.stem}"
    if name in sys.modules:
        return
    loader_spec = importlib.util.spec_from_file_location(name, path)
    if loader_spec is None or loader_spec.loader is None:
        raise ProjectError(f"{path}: cannot be imported as a Python module")
    module = importlib.util.module_from_spec(loader_spec)
    sys.modules[name] = module
    try:
        loader_spec.loader.exec_module(module)
    except VehilError:
        raise
    except Exception as exc:
        del sys.modules[name]
        raise ProjectError(f"{path}: importing the {kind} module failed: {exc!r}") from exc
