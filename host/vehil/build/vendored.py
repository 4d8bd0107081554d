"""Vendored libraries: third-party C or C++ used as is, described by a manifest.

A library sits in its own folder under `third_party/` (in vehil's tree or at the root
of a user's project, beside vehil.toml) with a `vehil-lib.toml` (docs/extending.md,
"A library you did not write"):

    [library]
    language = "c"                 # or "c++"
    standard = "c99"               # its -std= (default: vehil's, c99 or gnu++11)
    sources = ["src/filter.c"]     # paths or globs; nothing else in the folder is built
    include_dirs = ["src"]         # on every source's include path, as system headers
    defines = ["FILTER_N=2"]       # on every source too: the wrapper reads its headers
    warnings = ["-Wno-unused-parameter"]   # for its own sources only

Every build reads the same manifests (the AVR image through firmware/build_id.py, the
native board and the fuzzer through vehil/build/native.py), so a library builds alike
for the chip and for the host. Its own sources never get -Werror (a library is not
edited to satisfy our warnings), but they keep the chip-twin checks natively: code that
computes in double would make the native board compute in float64.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vehil.errors import BuildError
from vehil.paths import DATA_ROOT

MANIFEST = "vehil-lib.toml"
FOLDER = "third_party"
# The Arduino.h shim (firmware/arduino/Arduino.h), on every source's include path.
ARDUINO_SHIM_DIR = DATA_ROOT / "firmware" / "arduino"
LANGUAGES = {"c": (".c",), "c++": (".cpp", ".cc", ".cxx")}
_KEYS = {"language", "standard", "sources", "include_dirs", "defines", "warnings"}


@dataclass(frozen=True)
class Library:
    name: str
    root: Path
    language: str
    standard: str | None
    sources: tuple[Path, ...]
    include_dirs: tuple[Path, ...]
    defines: tuple[str, ...]
    warnings: tuple[str, ...]

    @property
    def cxx(self) -> bool:
        return self.language == "c++"

    def own_flags(self) -> list[str]:
        """What its sources get after vehil's flags: its standard, warnings as warnings,
        its manifest's warning flags."""
        std = [f"-std={self.standard}"] if self.standard else []
        return [*std, "-Wno-error", *self.warnings]


def _strings(where: str, key: str, value: Any) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise BuildError(f"{where}: library.{key}: a list of strings, got {value!r}")
    return value


def parse(path: Path) -> Library:
    """One manifest; errors name the file and the key."""
    where = str(path)
    root = path.parent.resolve()
    try:
        table = tomllib.loads(path.read_text()).get("library")
    except tomllib.TOMLDecodeError as exc:
        raise BuildError(f"{where}: not valid TOML: {exc}") from None
    if not isinstance(table, dict):
        raise BuildError(f"{where}: give one [library] table (docs/extending.md)")
    unknown = sorted(set(table) - _KEYS)
    if unknown:
        raise BuildError(
            f"{where}: library.{unknown[0]}: unknown key; allowed: {', '.join(sorted(_KEYS))}"
        )
    language = table.get("language", "c")
    if language not in LANGUAGES:
        raise BuildError(f'{where}: library.language: {language!r}; use "c" or "c++"')
    sources: list[Path] = []
    for pattern in _strings(where, "sources", table.get("sources", [])):
        matches = sorted(p for p in root.glob(pattern) if p.is_file())
        if not matches:
            raise BuildError(f"{where}: library.sources: {pattern!r} matches no file in {root}")
        for m in matches:
            if m.suffix not in LANGUAGES[language]:
                raise BuildError(
                    f"{where}: library.sources: {m.relative_to(root)} is not a {language} "
                    f"source ({', '.join(LANGUAGES[language])}); list headers in include_dirs"
                )
        sources += matches
    include_dirs = []
    for d in _strings(where, "include_dirs", table.get("include_dirs", ["."])):
        if not (root / d).is_dir():
            raise BuildError(f"{where}: library.include_dirs: no folder {root / d}")
        include_dirs.append((root / d).resolve())
    defines = _strings(where, "defines", table.get("defines", []))
    bad = [d for d in defines if not d.split("=", 1)[0].isidentifier()]
    if bad:
        raise BuildError(f"{where}: library.defines: {bad[0]!r} is not NAME or NAME=VALUE")
    warnings = _strings(where, "warnings", table.get("warnings", []))
    bad = [w for w in warnings if not w.startswith("-W")]
    if bad:
        raise BuildError(f"{where}: library.warnings: {bad[0]!r} is not a -W flag")
    standard = table.get("standard")
    if standard is not None and not isinstance(standard, str):
        raise BuildError(f'{where}: library.standard: a string such as "gnu11", got {standard!r}')
    return Library(
        name=root.name,
        root=root,
        language=language,
        standard=standard,
        sources=tuple(dict.fromkeys(sources)),
        include_dirs=tuple(include_dirs),
        defines=tuple(defines),
        warnings=tuple(warnings),
    )


def roots() -> list[Path]:
    """Where third_party/ folders are looked for: vehil's tree, then the project's."""
    from vehil import project

    found = [DATA_ROOT]
    current = project.current()
    if current is not None and current.root != DATA_ROOT:
        found.append(current.root)
    return found


def libraries(search: list[Path] | None = None) -> list[Library]:
    """Every vendored library, in a stable order; two of one name are refused."""
    libs: dict[str, Library] = {}
    for root in roots() if search is None else search:
        for manifest in sorted((root / FOLDER).glob(f"*/{MANIFEST}")):
            lib = parse(manifest)
            if lib.name in libs:
                raise BuildError(
                    f"two vendored libraries named {lib.name}: {libs[lib.name].root} and "
                    f"{lib.root}; rename one folder"
                )
            libs[lib.name] = lib
    return list(libs.values())


def include_flags(libs: list[Library]) -> list[str]:
    """For every source: the libraries' headers and the Arduino.h shim as system headers
    (a wrapper that includes a header with unused static functions still builds under
    -Werror), and their defines."""
    dirs = [ARDUINO_SHIM_DIR, *(d for lib in libs for d in lib.include_dirs)]
    return [
        *(arg for d in dict.fromkeys(dirs) for arg in ("-isystem", str(d))),
        *(f"-D{d}" for lib in libs for d in lib.defines),
    ]
