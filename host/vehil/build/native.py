"""The native board: firmware/lib and firmware/native (and a project's C) compiled into a
host shared library.

The C flags are platformio.ini's [vehil] c_flags, the ones the AVR image is built
with, so the same sources see the same warnings and the same language, and two more
that refuse arithmetic in `double` (CHIP_TWIN_FLAGS).
"""

from __future__ import annotations

import configparser
import os
import shlex
import subprocess
from collections.abc import Sequence
from pathlib import Path

from vehil.build import registry
from vehil.build.build_id import build_id_defines
from vehil.errors import BuildError
from vehil.paths import DATA_ROOT, NATIVE_LIB


def source_dirs(c_sources: Sequence[Path] = ()) -> tuple[Path, ...]:
    """The folders a host build compiles (every *.c) and includes: vehil's core, the
    host's port, a project's C."""
    return (DATA_ROOT / "firmware" / "lib", DATA_ROOT / "firmware" / "native", *c_sources)


# `double` is 32 bits on avr-gcc and 64 natively: C that computes in double would make the
# native board compute in float64 and stop being the chip's twin. These catch it (a float
# promoted to double, a double stored back into a float). Native only: avr-libc's math
# functions return double (expf is exp), so on the AVR they flag every call.
CHIP_TWIN_FLAGS = ("-Wdouble-promotion", "-Wfloat-conversion")


def c_flags() -> list[str]:
    """platformio.ini's [vehil] c_flags and the flags that keep native code float32."""
    ini = configparser.ConfigParser(interpolation=None, inline_comment_prefixes=(";",))
    ini.read(DATA_ROOT / "platformio.ini")
    return [*shlex.split(ini["vehil"]["c_flags"]), *CHIP_TWIN_FLAGS]


def build_native(
    estimators: str = "all", c_sources: Sequence[Path] = (), *, verbose: bool = False
) -> Path:
    """The native board's library holding `estimators` (registry.select's words), with the
    C in the `c_sources` folders; rebuilt when a source or header is newer."""
    dirs = source_dirs(c_sources)
    sources = sorted(p for d in dirs for p in d.rglob("*.c"))
    inputs = sources + [p for d in dirs for p in d.rglob("*.h")]
    chosen = registry.select(estimators, c_sources)
    registry_h = registry.write(NATIVE_LIB.parent / "gen", chosen, c_sources)
    gen = registry_h.parent
    inputs += [DATA_ROOT / "platformio.ini", registry_h]
    if NATIVE_LIB.exists() and all(p.stat().st_mtime <= NATIVE_LIB.stat().st_mtime for p in inputs):
        return NATIVE_LIB
    NATIVE_LIB.parent.mkdir(parents=True, exist_ok=True)
    defines = [f"-D{k}={v}" for k, v in build_id_defines()]
    cmd = [
        os.environ.get("CC", "cc"),
        *c_flags(),
        *defines,
        "-I",  # registry_gen.h: by default every estimator, those left out of the AVR image too
        str(gen),
        "-fPIC",
        "-shared",
        *(arg for d in dirs for arg in ("-I", str(d))),
        "-o",
        str(NATIVE_LIB),
        *map(str, sources),
        "-lm",
    ]
    if verbose:
        print(shlex.join(cmd))
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise BuildError(f"native library build failed:\n{proc.stderr.strip()}")
    return NATIVE_LIB
