"""The native board: firmware/lib, firmware/native, a project's C and the vendored
libraries compiled into a host shared library.

The flags are platformio.ini's [vehil] flags, the ones the AVR image is built with, so
the same sources see the same warnings and the same language, and two more that refuse
arithmetic in `double` (CHIP_TWIN_FLAGS), on vendored code too.
"""

from __future__ import annotations

import configparser
import os
import shlex
from collections.abc import Sequence
from pathlib import Path

from vehil.build import registry, vendored
from vehil.build.build_id import build_id_defines
from vehil.build.objects import Unit, compile_units, link
from vehil.paths import DATA_ROOT, NATIVE_LIB

_CXX_SUFFIXES = vendored.LANGUAGES["c++"]
# The one source that reports the build id (INFO): only it is rebuilt for a new commit.
_BUILD_ID_SOURCE = DATA_ROOT / "firmware" / "lib" / "board" / "dispatch.c"


def source_dirs(c_sources: Sequence[Path] = ()) -> tuple[Path, ...]:
    """The folders a host build compiles (every C and C++ source) and includes: vehil's
    core, the host's port, a project's C."""
    return (DATA_ROOT / "firmware" / "lib", DATA_ROOT / "firmware" / "native", *c_sources)


# `double` is 32 bits on avr-gcc and 64 natively: C that computes in double would make the
# native board compute in float64 and stop being the chip's twin. These catch it (a float
# promoted to double, a double stored back into a float), as errors even where -Werror is
# off (vendored code). Native only: avr-libc's math functions return double (expf is exp),
# so on the AVR they flag every call.
CHIP_TWIN_FLAGS = ("-Werror=double-promotion", "-Werror=float-conversion")


def _ini_flags(key: str) -> list[str]:
    ini = configparser.ConfigParser(interpolation=None, inline_comment_prefixes=(";",))
    ini.read(DATA_ROOT / "platformio.ini")
    return shlex.split(ini["vehil"][key])


def c_flags() -> list[str]:
    """platformio.ini's [vehil] flags and c_flags, and the flags that keep native code float32."""
    return [*_ini_flags("c_flags"), *_ini_flags("flags"), *CHIP_TWIN_FLAGS]


def cxx_flags() -> list[str]:
    """The same for C++: [vehil] flags and cxx_flags."""
    return [*_ini_flags("cxx_flags"), *_ini_flags("flags"), *CHIP_TWIN_FLAGS]


def units(
    gen: Path,
    extra: Sequence[str] = (),
    also: Sequence[Path] = (),
    c_sources: Sequence[Path] = (),
) -> list[Unit]:
    """Every source of the host build with its flags: vehil's, a project's (the
    `c_sources` folders) and `also` (a test harness) under -Werror, each vendored
    library's with its manifest's (vehil/build/vendored.py); `extra` for all (-fPIC).
    gen holds the build's registry_gen.h."""
    libs = vendored.libraries()
    dirs = source_dirs(c_sources)
    own = sorted(p for d in dirs for p in d.rglob("*") if p.suffix in (".c", *_CXX_SUFFIXES))
    common = [
        *extra,
        "-I",  # registry_gen.h: every estimator, those left out of the AVR image too
        str(gen),
        *(arg for d in dirs for arg in ("-I", str(d))),
        *vendored.include_flags(libs),
    ]

    def unit(source: Path, own: Sequence[str] = ()) -> Unit:
        cxx = source.suffix in _CXX_SUFFIXES
        lang = cxx_flags() if cxx else c_flags()
        if source == _BUILD_ID_SOURCE:
            own = [*own, *(f"-D{k}={v}" for k, v in build_id_defines())]
        return Unit(source, (*lang, *common, *own), cxx)

    return [
        *(unit(s) for s in [*own, *also]),
        *(unit(s, lib.own_flags()) for lib in libs for s in lib.sources),
    ]


def compilers() -> tuple[str, str]:
    return os.environ.get("CC", "cc"), os.environ.get("CXX", "c++")


def build_native(
    estimators: str = "all", c_sources: Sequence[Path] = (), *, verbose: bool = False
) -> Path:
    """The native board's library holding `estimators` (registry.select's words), with the
    C in the `c_sources` folders; each object rebuilt when its source or a header it
    includes changed."""
    chosen = registry.select(estimators, c_sources)
    gen = registry.write(NATIVE_LIB.parent / "gen", chosen, c_sources).parent
    cc, cxx = compilers()
    todo = units(gen, ["-fPIC"], c_sources=c_sources)
    objects = compile_units(todo, NATIVE_LIB.parent / "obj", cc=cc, cxx=cxx, verbose=verbose)
    driver = cxx if any(u.cxx for u in todo) else cc
    return link(objects, NATIVE_LIB, [driver, "-shared"], verbose=verbose)
