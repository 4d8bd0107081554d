"""Builds everything the boards run: the AVR image, the simavr bridge, the native library."""

from __future__ import annotations

import subprocess
from collections.abc import Sequence
from pathlib import Path

from vehil.build.native import build_native
from vehil.build.platformio import build_firmware
from vehil.errors import BuildError
from vehil.paths import PROJECT_ROOT, SIMAVR_BRIDGE

PARTS = ("firmware", "firmware-ev", "sim", "native")


def build_simavr_bridge(*, verbose: bool = False) -> Path:
    proc = subprocess.run(["make", "-C", str(PROJECT_ROOT / "sim")], capture_output=True, text=True)
    if verbose:
        print(proc.stdout + proc.stderr)
    if proc.returncode != 0:
        raise BuildError(f"simavr bridge build failed (make -C sim):\n{proc.stderr.strip()}")
    return SIMAVR_BRIDGE


def build(parts: Sequence[str] = PARTS, *, verbose: bool = False) -> dict[str, Path]:
    """Builds the named parts (incrementally); returns where each product is."""
    steps = {
        "firmware": lambda: build_firmware(verbose=verbose),
        "firmware-ev": lambda: build_firmware("offline-ev", verbose=verbose),
        "sim": lambda: build_simavr_bridge(verbose=verbose),
        "native": lambda: build_native(verbose=verbose),
    }
    built = {part: steps[part]() for part in parts}
    if "native" in parts:
        check_interfaces()
    return built


def check_interfaces() -> None:
    """Every estimator's C against its spec, on the native board (vehil/build/interface.py)."""
    from vehil.boards import open_board
    from vehil.build.interface import check
    from vehil.estimators import estimators

    with open_board("native") as link:
        problems = check(link, estimators().values(), every_spec_built=True)
    if problems:
        raise BuildError(
            "the estimators' C and their Python specs disagree (fix one to match the other):\n  "
            + "\n  ".join(problems)
        )
