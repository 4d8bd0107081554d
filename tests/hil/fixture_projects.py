"""vehil projects kept under tests/fixtures, driven as their users would: vehil and pytest
run in the project's folder, with a build cache of the project's own."""

import fcntl
import os
import subprocess
import sys
from pathlib import Path

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"


def vehil_python(
    *argv: str, cwd: Path, cache: Path, timeout: float = 900
) -> subprocess.CompletedProcess:
    """Python in a project's folder, with a cache of its own."""
    env = {k: v for k, v in os.environ.items() if k != "VEHIL_PROJECT"}
    env["VEHIL_CACHE"] = str(cache)
    return subprocess.run(
        [sys.executable, *argv],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def project_pytest(target: str, project: Path, cache: Path) -> subprocess.CompletedProcess:
    """pytest in a project's folder, as its CI would run it: vehil's plugin, none of
    vehil's own conftest files."""
    where = str(project)
    return vehil_python(
        "-m",
        "pytest",
        "-q",
        "-p",
        "no:cacheprovider",
        "--confcutdir",
        where,
        "--rootdir",
        where,
        target,
        cwd=project,
        cache=cache,
    )


def build(project: Path, cache: Path) -> subprocess.CompletedProcess:
    """`vehil build` in the project, one worker at a time (they share its cache); it must
    succeed."""
    cache.mkdir(parents=True, exist_ok=True)
    with (cache / ".lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        built = vehil_python("-m", "vehil", "build", cwd=project, cache=cache)
    assert built.returncode == 0, built.stdout + built.stderr
    return built
