"""Host builds from objects: each source compiled on its own, again only when it, a header
it includes (from anywhere: the compiler's dependency file lists them) or its command
changed; then linked. The native board and the fuzzer build this way."""

from __future__ import annotations

import hashlib
import os
import shlex
import subprocess
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from vehil.errors import BuildError


@dataclass(frozen=True)
class Unit:
    """One source and everything its command line needs but the compiler's name, -c,
    -o and the dependency flags."""

    source: Path
    flags: tuple[str, ...]
    cxx: bool = False


def _dependencies(dep_file: Path) -> list[Path]:
    """The files a make-style dependency file lists (the object's prerequisites)."""
    text = dep_file.read_text().replace("\\\n", " ")
    _, _, prerequisites = text.partition(":")
    return [Path(p) for p in shlex.split(prerequisites.splitlines()[0] if prerequisites else "")]


def _fresh(obj: Path, dep_file: Path, cmd_file: Path, cmd: str) -> bool:
    if not (obj.exists() and dep_file.exists() and cmd_file.exists()):
        return False
    if cmd_file.read_text() != cmd:
        return False
    built = obj.stat().st_mtime
    return all(p.exists() and p.stat().st_mtime <= built for p in _dependencies(dep_file))


def compile_units(
    units: Sequence[Unit], obj_dir: Path, *, cc: str, cxx: str, verbose: bool = False
) -> list[Path]:
    """Each unit's object under obj_dir (named by its source and flags), compiled only
    when stale; several at a time. Errors give the compiler's message."""
    obj_dir.mkdir(parents=True, exist_ok=True)

    def one(unit: Unit) -> tuple[Path, str | None]:
        key = hashlib.sha1(f"{unit.source}\0{unit.flags}".encode()).hexdigest()[:10]
        obj = obj_dir / f"{unit.source.stem}-{key}.o"
        dep_file, cmd_file = obj.with_suffix(".d"), obj.with_suffix(".cmd")
        argv = [cxx if unit.cxx else cc, *unit.flags, "-c", str(unit.source), "-o", str(obj)]
        cmd = shlex.join(argv)
        if _fresh(obj, dep_file, cmd_file, cmd):
            return obj, None
        if verbose:
            print(cmd)
        proc = subprocess.run([*argv, "-MMD", "-MF", str(dep_file)], capture_output=True, text=True)
        if proc.returncode != 0:
            return obj, f"{unit.source}:\n{proc.stderr.strip()}"
        cmd_file.write_text(cmd)
        return obj, None

    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        done = list(pool.map(one, units))
    errors = [e for _, e in done if e is not None]
    if errors:
        raise BuildError("compiling failed:\n" + "\n".join(errors))
    return [obj for obj, _ in done]


def link(
    objects: Sequence[Path],
    out: Path,
    argv: Sequence[str],
    libs: Sequence[str] = ("-lm",),
    *,
    verbose: bool = False,
) -> Path:
    """argv (the linker driver and its flags), the objects, then libs into out, unless out
    is newer than every object and was linked by the same command."""
    cmd = shlex.join([*argv, "-o", str(out), *map(str, objects), *libs])
    cmd_file = out.with_name(out.name + ".cmd")
    if (
        out.exists()
        and cmd_file.exists()
        and cmd_file.read_text() == cmd
        and all(o.stat().st_mtime <= out.stat().st_mtime for o in objects)
    ):
        return out
    if verbose:
        print(cmd)
    proc = subprocess.run(shlex.split(cmd), capture_output=True, text=True)
    if proc.returncode != 0:
        raise BuildError(f"linking {out.name} failed:\n{proc.stderr.strip()}")
    cmd_file.write_text(cmd)
    return out
