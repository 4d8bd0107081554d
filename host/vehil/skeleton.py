"""`vehil new project` and `vehil new estimator`: the files a project and an estimator
start from, written so that they build and pass as they are (docs/extending.md).

A project: vehil.toml (specs/*.py, c/, scenarios/), .gitignore, empty folders. An
estimator NAME in it: specs/NAME.py (the spec and its float64 reference), c/NAME.h and
c/NAME.c (float32 and fixed point), a scenario per mode and a pytest test that runs them
on the native board, simavr and QEMU. The estimator is a first-order low-pass,
x += k (y - x), on the noisy_sine plant: small enough to read in a minute and to replace.
With --wrap HEADER, the estimator wraps a library vendored in third_party/: its manifest
if it has none, and a C or C++ wrapper holding the library's type in an opaque,
size-checked slot (docs/extending.md, "A library you did not write"); float32 only.
"""

from __future__ import annotations

import re
import textwrap
from pathlib import Path
from string import Template

from vehil import project
from vehil.errors import VehilError

FIRST_USER_ID = 100  # vehil's own estimators keep below
_NAME = re.compile(r"^[a-z][a-z0-9_]{0,14}$")  # a C identifier, ESTIMATOR_NAME_SIZE - 1 long


class SkeletonError(VehilError):
    """A skeleton cannot be written: the message says why and what to do."""


PROJECT_TOML = """\
# A vehil project (docs/extending.md): your estimators' specs, their C, your scenarios.
[project]
name = "$project"
estimators = ["specs/*.py"]   # modules that register EstimatorSpecs
plants = ["plants/*.py"]      # modules that register PlantSpecs
scenarios = "scenarios"       # found by name before vehil's own
c_sources = ["c"]             # NAME.h + NAME.c per estimator, compiled into the image
# image = ["my_filter"]       # the image's estimators (default: every one in c_sources)
"""

GITIGNORE = """\
.vehil/
runs/
__pycache__/
"""

SPEC = '''\
"""$name: $title.

The skeleton `vehil new estimator` wrote: a first-order low-pass, x += k (y - x). Replace
the maths and keep the shape: the spec is the interface's one statement, the reference
is the same step in float64, c/$name.c the board's (docs/extending.md).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from vehil.estimators import register
from vehil.estimators.base import EstimatorSpec, Param, Signal


class $cls:
    """The float64 reference: step([y]) -> [x], as c/$name.c does it."""

    def __init__(self, p: Mapping[str, float]):
        self.k = p["k"]
        self.x: float | None = None

    def step(self, u: np.ndarray) -> np.ndarray:
        y = float(u[0])
        self.x = y if self.x is None else self.x + self.k * (y - self.x)  # first sample: x = y
        return np.array([self.x])


SPEC = register(
    EstimatorSpec(
        name="$name",  # the C descriptor's name too
        c_id=$c_id,  # the C descriptor's wire id: unique in the image
        title="$title",
        inputs=(Signal("y", "1", q=24, doc="the measured signal, Q7.24: |y| < 128"),),
        outputs=(Signal("y", "1", q=24, doc="its low-passed estimate"),),
        params=(Param("k", "1", q=30, default=0.2, lo=0.0, hi=1.0, doc="gain per sample"),),
        reference=$cls,
        modes=$modes,
    )
)
'''

HEADER = """\
/* $name: $title. A first-order low-pass, x += k (y - x) (specs/$name.py says the
 * interface; docs/extending.md the contract). */
#ifndef ${guard}_H
#define ${guard}_H

#include "estimators/estimator.h"

#define ${guard}_ID ${c_id}u

typedef struct {
    uint8_t mode;     /* MODE_F32 or MODE_FIXED */
    uint8_t started;  /* the first sample sets the estimate */
    float k, x;       /* F32 */
    int32_t k_q, x_q; /* FIXED: k in Q30 (the parameter's q), x in Q24 (the signal's) */
} ${name}_state_t;

extern const ROM estimator_t ${name}_estimator;

#endif
"""

# The float32 step both templates write: the low-pass, a NaN or infinite input held out.
F32_STEP = """\
float y = get_f32(in);
if (!isfinite(y)) {
    status |= STATUS_NOT_FINITE; /* contained: the estimate is held */
} else if (!s->started) {
    s->x = y;
    s->started = 1u;
} else {
    s->x += s->k * (y - s->x);$note
}
put_f32(out, s->x);"""


def _f32_step(indent: str, note: str = "") -> str:
    return textwrap.indent(Template(F32_STEP).substitute(note=note), indent)


SOURCE = """\
#include "$name.h"

#include <math.h>

#include "estimators/params.h"
#include "fixmath/fixmath.h"
#include "proto/wire.h"

#define N_PARAMS 1u
#define Q_K 30u /* the spec's q of k */
#define Q_Y 24u /* the spec's q of y, in and out */

/* The spec's parameters in its order: {lo, hi, q}, in flash. */
static const ROM param_range_t ranges[N_PARAMS] = {{0.0f, 1.0f, Q_K}};

static void ${name}_reset(void *state)
{
    ${name}_state_t *s = state;
    s->started = 0u;
    s->x = 0.0f;
    s->x_q = 0;
}

static uint8_t ${name}_configure(void *state, uint8_t mode, const uint8_t *params)
{
    ${name}_state_t *s = state;
    uint8_t bad = params_check(params, mode, ranges, N_PARAMS);
    if (bad != 0u) {
        return bad; /* 1 + the index of the first bad parameter: nothing kept */
    }
    s->mode = mode;
    s->k = param_value(params, 0, mode, Q_K);
    s->k_q = mode == MODE_FIXED ? param_q(params, 0) : 0;
    ${name}_reset(s);
    return 0;
}

static uint8_t ${name}_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                        uint8_t *out_len)
{
    ${name}_state_t *s = state;
    uint8_t status = 0;
    (void)in_len; /* the dispatcher checked it: n_inputs values */
    if (s->mode == MODE_FIXED) {
        int32_t y = get_i32(in);
        if (!s->started) {
            s->x_q = y;
            s->started = 1u;
        } else { /* saturating: y - x leaves Q7.24 only near its ends, and is then flagged */
            int32_t e = fx_sub(y, s->x_q, &status);
            s->x_q = fx_add(s->x_q, fx_mul_rs(s->k_q, e, Q_K, &status), &status);
        }
        put_i32(out, s->x_q);
    } else {
${f32_step}
    }
    *out_len = ESTIMATOR_VALUE_SIZE;
    return status;
}

const ROM estimator_t ${name}_estimator = {
    .id = ${guard}_ID,
    .name = "$name",
    .modes = (1u << MODE_F32) | (1u << MODE_FIXED),
    .n_inputs = 1,
    .n_outputs = 1,
    .n_params = N_PARAMS,
    .configure = ${name}_configure,
    .reset = ${name}_reset,
    .step = ${name}_step,
};
"""

SCENARIO = """\
# $name on a noisy sine, $mode (the skeleton `vehil new estimator` wrote).
[scenario]
title = "$name on a noisy sine, $mode"
duration = 2.0           # s
sample_time = 0.002      # s
seed = 1

[plant]
name = "noisy_sine"      # y: a 0.5 Hz sine of amplitude 2 with noise of 0.05 RMS
amplitude = 2.0
frequency = 0.5
noise_std = 0.05

[estimator]
name = "$name"
mode = "$mode"

[estimator.params]
k = 0.2

[tolerance.y]
$tolerance
truth_rms = 0.06         # the filter's lag and the noise it lets through: 0.040 measured
"""

# How far rounding alone takes each mode from the float64 reference on this drive, with
# margin: max |board - reference| measured 1.9e-7 in float32, 8.8e-8 in Q7.24.
TOLERANCES = {
    "F32": "abs = 1e-6               # |board - reference| <= abs at every sample",
    "FIXED": "abs = 1e-6\nbit_exact = true         # the board's bits equal the native build's",
}

TEST = '''\
"""$name against its float64 reference on the native board, simavr and QEMU, in both
numeric modes (run_scenario comes from vehil's pytest plugin)."""

import pytest


@pytest.mark.parametrize("board", ["native", "simavr", "qemu"])
@pytest.mark.parametrize("mode", $modes)
def test_${name}_follows_its_reference(run_scenario, board: str, mode: str) -> None:
    run_scenario("$name/sine-" + mode, board=board).assert_passed()
'''


def _write(files: dict[Path, str]) -> list[Path]:
    """Writes every file, or none if one is there already (named)."""
    there = [path for path in files if path.exists()]
    if there:
        raise SkeletonError(
            f"{there[0]} exists already: nothing written (move it or pick another name)"
        )
    for path, text in files.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return list(files)


def new_project(folder: Path, name: str | None = None) -> list[Path]:
    """A project in `folder` (made if missing): vehil.toml, .gitignore and its folders."""
    folder = folder.resolve()
    files = {
        folder / project.FILE_NAME: Template(PROJECT_TOML).substitute(project=name or folder.name),
        folder / ".gitignore": GITIGNORE,
        **{folder / sub / ".gitkeep": "" for sub in ("specs", "plants", "c", "scenarios", "tests")},
    }
    return _write(files)


def _free_id() -> int:
    from vehil.estimators import estimators

    used = {spec.c_id for spec in estimators().values()}
    return next(i for i in range(FIRST_USER_ID, 256) if i not in used)


def _start(name: str, title: str | None) -> tuple[project.Project, Path, dict[str, object]]:
    """The current project, its scenarios folder and the templates' words for `name`."""
    here = project.current()
    if here is None:
        raise SkeletonError(
            f"no {project.FILE_NAME} here or above: run `vehil new project` first, or cd into one"
        )
    if not _NAME.match(name):
        raise SkeletonError(
            f"estimator name {name!r}: lower-case letters, digits and _, a letter first, "
            "15 characters at most (it names the C descriptor and its types)"
        )
    from vehil.build import registry
    from vehil.estimators import estimators

    if name in estimators() or name in registry.available():
        raise SkeletonError(f"estimator name {name!r} is taken: pick another")
    if not here.c_sources:
        raise SkeletonError(f"{here.root / project.FILE_NAME}: give project.c_sources (a folder)")
    words = {
        "name": name,
        "title": title or f"{name} (first-order low-pass)",
        "cls": "".join(w.capitalize() for w in name.split("_")) + "Reference",
        "guard": name.upper(),
        "c_id": _free_id(),
        "modes": '("F32", "FIXED")',
    }
    return here, here.scenarios or here.root / "scenarios", words


def _write_checked(here: project.Project, files: dict[Path, str]) -> list[Path]:
    written = _write(files)
    found = project.parse(here.root / project.FILE_NAME)
    if files and next(iter(files)) not in found.estimators:
        raise SkeletonError(
            f"wrote {written[0]}, which {here.root / project.FILE_NAME}'s project.estimators "
            'does not match: add "specs/*.py" to it'
        )
    return written


def new_estimator(name: str, title: str | None = None) -> list[Path]:
    """Estimator `name` in the current project: spec, reference, C, scenarios, test."""
    here, scenarios, words = _start(name, title)
    files = {
        here.root / "specs" / f"{name}.py": Template(SPEC).substitute(words),
        here.c_sources[0] / f"{name}.h": Template(HEADER).substitute(words),
        here.c_sources[0] / f"{name}.c": Template(SOURCE).substitute(
            words, f32_step=_f32_step(8 * " ")
        ),
        **{
            scenarios / name / f"sine-{mode.lower()}.toml": Template(SCENARIO).substitute(
                words, mode=mode, tolerance=TOLERANCES[mode]
            )
            for mode in ("F32", "FIXED")
        },
        here.root / "tests" / f"test_{name}.py": Template(TEST).substitute(
            words, modes='["f32", "fixed"]'
        ),
    }
    return _write_checked(here, files)


WRAP_HEADER = """\
/* $name: $title. A wrapper around third_party/$lib ($header): the library's $type
 * lives in an opaque slot, which only $source sees the type of (its header is included
 * there alone: a header-only library may have no include guard). */
#ifndef ${guard}_H
#define ${guard}_H

#include "estimators/estimator.h"

#ifdef __cplusplus
extern "C" {
#endif

#define ${guard}_ID ${c_id}u

typedef struct {
    VEHIL_SLOT(64) lib; /* $type: $source checks that it fits (raise 64 if it says so) */
    float k, x;         /* the skeleton's low-pass: replace with the library's calls */
    uint8_t started;
} ${name}_state_t;

extern const ROM estimator_t ${name}_estimator;

#ifdef __cplusplus
}
#endif

#endif
"""

WRAP_SOURCE = """\
#include "$name.h"

#include <math.h>
#include <string.h>

#include "$include"
#include "estimators/params.h"
#include "proto/wire.h"

VEHIL_SLOT_CHECK($type, ${name}_state_t, lib);

#define N_PARAMS 1u

/* The spec's parameters in its order: {lo, hi, q}, in flash. */
static const ROM param_range_t ranges[N_PARAMS] = {{0.0f, 1.0f, 30}};

static void ${name}_reset(void *state)
{
    ${name}_state_t *s = (${name}_state_t *)state;
    /* Set the library's object up again here, from the parameters configure kept: for a C
     * struct its init function on VEHIL_SLOT_AS($type, s->lib), for a C++ class `$type fresh(...);
     * memcpy(s->lib.bytes_, &fresh, sizeof fresh);` (no placement new: avr-g++ has no
     * <new>). Until then its slot is zeroed. */
    memset(s->lib.bytes_, 0, sizeof s->lib);
    s->started = 0u;
    s->x = 0.0f;
}

static uint8_t ${name}_configure(void *state, uint8_t mode, const uint8_t *params)
{
    ${name}_state_t *s = (${name}_state_t *)state;
    uint8_t bad = params_check(params, mode, ranges, N_PARAMS);
    if (bad != 0u) {
        return bad; /* 1 + the index of the first bad parameter: nothing kept */
    }
    s->k = param_value(params, 0, mode, param_range_q(ranges, 0));
    ${name}_reset(s);
    return 0;
}

static uint8_t ${name}_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                        uint8_t *out_len)
{
    ${name}_state_t *s = (${name}_state_t *)state;
    uint8_t status = 0;
    (void)in_len; /* the dispatcher checked it: n_inputs values */
${f32_step}
    *out_len = ESTIMATOR_VALUE_SIZE;
    return status;
}

/* Positional (C++ before C++20 has no designated initialisers): id, modes, n_inputs,
 * n_outputs, n_params, configure, reset, step, name. */
const ROM estimator_t ${name}_estimator = {
    ${guard}_ID, 1u << MODE_F32, 1, 1, N_PARAMS, ${name}_configure, ${name}_reset, ${name}_step,
    "$name",
};
"""

WRAP_MANIFEST = """\
# $lib as it came (docs/extending.md, "A library you did not write"): what vehil builds of
# it. Written by `vehil new estimator --wrap`; check the sources and add its defines.
[library]
language = "$language"
sources = $sources
include_dirs = ["$include_dir"]
defines = []
"""

_CLASS = re.compile(r"^\s*class\s+(\w+)[^;]*$", re.M)
_TYPEDEF = re.compile(r"typedef\s+struct\s*\w*\s*\{.*?\}\s*(\w+)\s*;", re.S)


def _library_of(here: project.Project, header: Path) -> Path:
    from vehil.build import vendored

    folder = here.root / vendored.FOLDER
    try:
        lib = folder / header.relative_to(folder).parts[0]
    except ValueError:
        raise SkeletonError(
            f"{header} is not in {folder}: copy the library's folder there as it came, "
            "then give its header"
        ) from None
    if not header.is_file():
        raise SkeletonError(f"{header}: no such header")
    return lib


def new_wrapper(name: str, header: Path, title: str | None = None) -> list[Path]:
    """Estimator `name` wrapping a vendored library: its manifest (if it has none), a C or
    C++ wrapper with the library's type in an opaque, size-checked slot, the spec and its
    float64 reference, a scenario and a test (float32: a library's own numbers)."""
    from vehil.build import vendored

    title = title or f"{name} (wraps {header.name})"
    here, scenarios, words = _start(name, title)
    header = header.resolve()
    lib = _library_of(here, header)
    text = header.read_text(errors="replace")
    cxx = bool(_CLASS.search(text)) or any(header.parent.glob("*.cpp"))
    found = (_CLASS if cxx else _TYPEDEF).search(text)
    if found is None:
        raise SkeletonError(
            f"{header}: no {'class' if cxx else 'typedef struct'} found, so no type for the "
            "wrapper's slot: give the header that declares the library's state"
        )
    files: dict[Path, str] = {}
    manifest = lib / vendored.MANIFEST
    if manifest.exists():
        include_dir = next(
            (d for d in vendored.parse(manifest).include_dirs if d in header.parents), None
        )
        if include_dir is None:
            raise SkeletonError(f"{manifest}: no include_dirs entry holds {header}: add one")
    else:
        include_dir = header.parent
        suffix = ".cpp" if cxx else ".c"
        pattern = f"{header.parent.relative_to(lib).as_posix()}/*{suffix}".removeprefix("./")
        has_sources = any(header.parent.glob(f"*{suffix}"))
        files[manifest] = Template(WRAP_MANIFEST).substitute(
            lib=lib.name,
            language="c++" if cxx else "c",
            sources=f'["{pattern}"]' if has_sources else "[]",
            include_dir=include_dir.relative_to(lib).as_posix(),
        )
    source = here.c_sources[0] / f"{name}{'.cpp' if cxx else '.c'}"
    wrap = {
        **words,
        "lib": lib.name,
        "header": header.relative_to(lib).as_posix(),
        "type": found.group(1),
        "source": source.name,
        "include": header.relative_to(include_dir).as_posix(),
        "modes": '("F32",)',
    }
    files = {
        here.root / "specs" / f"{name}.py": Template(SPEC).substitute(wrap),
        here.c_sources[0] / f"{name}.h": Template(WRAP_HEADER).substitute(wrap),
        source: Template(WRAP_SOURCE).substitute(
            wrap,
            f32_step=_f32_step(
                4 * " ", f" /* the skeleton's: VEHIL_SLOT_AS({found.group(1)}, s->lib)'s */"
            ),
        ),
        scenarios / name / "sine-f32.toml": Template(SCENARIO).substitute(
            wrap, mode="F32", tolerance=TOLERANCES["F32"]
        ),
        here.root / "tests" / f"test_{name}.py": Template(TEST).substitute(wrap, modes='["f32"]'),
        **files,
    }
    return _write_checked(here, files)
