"""vehil as a user gets it: the wheel built from this tree, installed in a fresh venv,
a project and an estimator made by `vehil new` in an empty folder, an image with only
that estimator, and the estimator's scenarios passing on the native board, simavr and
QEMU through the test `vehil new` wrote.

The venv gets vehil from the wheel alone; its dependencies (numpy, PlatformIO...) are
this environment's, reached through a path file, so the test needs no package index.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

from vehil.paths import DATA_ROOT

pytestmark = [pytest.mark.hil, pytest.mark.long]

# What the wheel is built from: the tree less its build products, caches and hidden
# folders (.git, .venv, .pio, .hypothesis..., which other tests may be writing).
_TOP_NOT_SOURCES = shutil.ignore_patterns(".*", "build", "runs")
_ANYWHERE = shutil.ignore_patterns("*.egg-info", "__pycache__")


def _not_sources(folder: str, names: list[str]) -> set[str]:
    top = _TOP_NOT_SOURCES(folder, names) if Path(folder) == DATA_ROOT else set()
    return set(top) | set(_ANYWHERE(folder, names))


def _run(argv: list[str], cwd: Path, env: dict[str, str]) -> str:
    proc = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"{' '.join(argv)} in {cwd}:\n{proc.stdout}\n{proc.stderr}"
    return proc.stdout


def test_a_new_estimator_from_the_wheel_builds_alone_and_passes_on_every_board(
    tmp_path: Path,
) -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("VEHIL_PROJECT", "VEHIL_CACHE")}
    env["XDG_CACHE_HOME"] = str(tmp_path / "cache")  # vehil's per-user cache, outside a project

    source = tmp_path / "source"
    shutil.copytree(DATA_ROOT, source, ignore=_not_sources)
    wheels = tmp_path / "wheels"
    pip_wheel = [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(wheels)]
    _run([*pip_wheel, str(source)], tmp_path, env)
    (wheel,) = wheels.glob("vehil-*.whl")

    # The venv has no pip of its own (seeding one takes longer than the rest of the
    # install): ours installs the wheel into it.
    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)], tmp_path, env)
    python = venv / "bin" / "python"
    pip_install = [sys.executable, "-m", "pip", "--python", str(python), "install", "-q"]
    _run([*pip_install, "--no-deps", str(wheel)], tmp_path, env)
    site = Path(
        _run(
            [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            tmp_path,
            env,
        ).strip()
    )
    (site / "vehil-test-deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    vehil = str(venv / "bin" / "vehil")

    work = tmp_path / "empty"
    work.mkdir()
    _run([vehil, "new", "project", "filters"], work, env)
    project = work / "filters"
    _run([vehil, "new", "estimator", "smooth"], project, env)
    built = _run([vehil, "build"], project, env)
    assert "RAM left for your estimators" in built

    where = json.loads(
        _run(
            [
                str(python),
                "-c",
                "import json, vehil.paths as p; print(json.dumps("
                "[str(p.DATA_ROOT), str(p.CACHE_ROOT), p.IN_CHECKOUT]))",
            ],
            project,
            env,
        )
    )
    assert where == [str(site / "vehil" / "data"), str(project / ".vehil"), False]
    assert not list((site / "vehil").rglob("*.elf")) and not list((site / "vehil").rglob("*.so"))

    info = json.loads(_run([vehil, "info", "--board", "simavr", "--json"], project, env))
    assert info["info"]["estimators"] == 2  # passthrough (the link's) and smooth alone

    # The test `vehil new estimator` wrote: both modes on native, simavr and QEMU.
    out = _run([str(python), "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests"], project, env)
    assert "6 passed" in out
