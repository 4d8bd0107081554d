"""Two libraries used as they came, through their manifests (tests/fixtures/vendoring):
a header-only C alpha-beta tracker (static functions, no include guard, `double` unless
configured) and an Arduino-style C++ class whose .cpp includes Arduino.h, each wrapped as
an estimator in an opaque, size-checked state slot. The project's image holds only them;
they run on the native board, simavr and QEMU with the same bits, within float32's
rounding of the float64 reference (the project's own check_boards.py)."""

import shutil
import subprocess

import pytest
from fixture_projects import FIXTURES, build, project_pytest, vehil_python

from vehil.paths import BUILD_DIR

pytestmark = [pytest.mark.hil, pytest.mark.long]

PROJECT = FIXTURES / "vendoring"
CACHE = BUILD_DIR / "vendoring-fixture"  # kept between runs: the builds are incremental


def _vehil(*argv: str) -> subprocess.CompletedProcess:
    return vehil_python("-m", "vehil", *argv, cwd=PROJECT, cache=CACHE)


@pytest.fixture(scope="module")
def project_built() -> subprocess.CompletedProcess:
    return build(PROJECT, CACHE)


def test_the_image_holds_the_two_wrappers_and_no_example_of_the_libraries(project_built) -> None:  # noqa: ANN001
    info = _vehil("info", "--board", "simavr")
    assert info.returncode == 0, info.stderr
    assert "abf_speed (F32" in info.stdout and "speed_obs (F32" in info.stdout
    assert "manf" not in info.stdout  # only the project's estimators (and passthrough)
    objects = {p.stem for p in CACHE.rglob("*.o")}
    assert any(o.startswith("SpeedObserver") for o in objects)
    assert not any(o.startswith(("demo", "host_test", "Basic")) for o in objects)


def test_on_native_simavr_and_qemu_the_same_bits_within_float64(project_built) -> None:  # noqa: ANN001
    """The project's own check (check_boards.py), run as its CI would: pytest in its
    folder, vehil's pytest plugin running the scenarios on each board."""
    done = project_pytest("check_boards.py", PROJECT, CACHE)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "2 passed" in done.stdout


def test_a_wrapper_skeleton_builds_and_passes_as_written(tmp_path) -> None:  # noqa: ANN001
    """`vehil new estimator NAME --wrap HEADER` for a C library with no manifest (one is
    written) and for the C++ class (its manifest kept); the project built; the tests it
    wrote pass on every board."""
    project = tmp_path / "project"
    shutil.copytree(PROJECT, project, ignore=shutil.ignore_patterns(".vehil", "__pycache__"))
    toml = project / "vehil.toml"
    toml.write_text(
        "".join(line for line in toml.read_text().splitlines(True) if "image" not in line)
    )
    lib = project / "third_party" / "ringavg"
    lib.mkdir()
    (lib / "ringavg.h").write_text(
        "typedef struct ringavg_s {\n    float sum;\n    int n;\n} ringavg_t;\n"
        "void ringavg_init(ringavg_t *r);\n"
    )
    (lib / "ringavg.c").write_text(
        '#include "ringavg.h"\nvoid ringavg_init(ringavg_t *r) { r->sum = 0; r->n = 0; }\n'
    )

    # kept between runs, as vehil's own objects are (the copy's are rebuilt: a new path)
    cache = BUILD_DIR / "vendoring-skeleton"

    def vehil(*argv: str) -> subprocess.CompletedProcess:
        return vehil_python("-m", "vehil", *argv, cwd=project, cache=cache)

    for name, header in (
        ("ring_wrap", "third_party/ringavg/ringavg.h"),
        ("obs_wrap", "third_party/SpeedObserver/src/SpeedObserver.h"),
    ):
        made = vehil("new", "estimator", name, "--wrap", header)
        assert made.returncode == 0, made.stdout + made.stderr
    manifest = (lib / "vehil-lib.toml").read_text()
    assert 'language = "c"' in manifest and 'sources = ["*.c"]' in manifest
    wrapper = (project / "c" / "obs_wrap.cpp").read_text()
    assert "VEHIL_SLOT_CHECK(SpeedObserver, obs_wrap_state_t, lib);" in wrapper
    built = vehil("build")
    assert built.returncode == 0, built.stdout + built.stderr
    tests = project_pytest("tests", project, cache)
    assert tests.returncode == 0, tests.stdout + tests.stderr
    assert "6 passed" in tests.stdout
