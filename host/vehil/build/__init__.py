"""Builds everything the boards run: the AVR image, the simavr bridge, the native library.

In a project (vehil.toml), the image and the native library hold the estimators its
`image` names, with its own C compiled in (its `c_sources`); vehil's own builds otherwise.
"""

from __future__ import annotations

import subprocess
from collections.abc import Sequence
from pathlib import Path

from vehil import project
from vehil.build.native import build_native
from vehil.build.platformio import build_firmware, build_image, check_boot_baud
from vehil.errors import BuildError
from vehil.paths import DATA_ROOT, PROJECT_IMAGE, SIMAVR_BRIDGE

PARTS = ("firmware", "firmware-ev", "sim", "native")
PROJECT_PARTS = ("firmware", "sim", "native")  # a project's image is its set: no EV image


def build_simavr_bridge(*, verbose: bool = False) -> Path:
    # The bridge's objects go to the cache: vehil's sim/ may be an installed package's.
    cmd = ["make", "-C", str(DATA_ROOT / "sim"), f"BUILD={SIMAVR_BRIDGE.parent}"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if verbose:
        print(proc.stdout + proc.stderr)
    if proc.returncode != 0:
        raise BuildError(f"simavr bridge build failed (make -C sim):\n{proc.stderr.strip()}")
    return SIMAVR_BRIDGE


def project_image(here: project.Project) -> str:
    """The estimators a project's image holds: its vehil.toml's `image`, or else every
    estimator its own C declares, and passthrough (the link's) in any case."""
    if here.image is not None:
        return here.image
    from vehil.build import registry

    own = [n for n in registry.available(here.c_sources) if n not in registry.available()]
    return " ".join([registry.FIRST, *own])


def default_parts() -> tuple[str, ...]:
    return PROJECT_PARTS if project.current() is not None else PARTS


def build(
    parts: Sequence[str] | None = None, *, boot_baud: int | None = None, verbose: bool = False
) -> dict[str, Path]:
    """Builds the named parts (incrementally), the firmware's UART booting at `boot_baud`
    (None: its default); returns where each product is."""
    if boot_baud is not None:
        check_boot_baud(boot_baud)  # before anything is built
    here = project.current()
    if here is None:
        steps = {
            "firmware": lambda: build_firmware("offline", boot_baud=boot_baud, verbose=verbose),
            "firmware-ev": lambda: build_firmware(
                "offline-ev", boot_baud=boot_baud, verbose=verbose
            ),
            "native": lambda: build_native(verbose=verbose),
        }
    else:
        chosen, c_sources = project_image(here), here.c_sources
        steps = {
            "firmware": lambda: build_image(
                chosen, c_sources, key=PROJECT_IMAGE, boot_baud=boot_baud, verbose=verbose
            ),
            "native": lambda: build_native(chosen, c_sources, verbose=verbose),
        }
    steps["sim"] = lambda: build_simavr_bridge(verbose=verbose)
    parts = default_parts() if parts is None else parts
    unknown = [p for p in parts if p not in steps]
    if unknown:
        raise BuildError(f"{unknown[0]}: not a part of this build (parts: {', '.join(steps)})")
    built = {part: steps[part]() for part in parts}
    if "native" in parts:
        check_interfaces(every_spec_built=here is None)
    return built


def check_interfaces(*, every_spec_built: bool = True) -> None:
    """Every estimator's C against its spec, on the native board (vehil/build/interface.py).
    A project's native board holds its image's estimators only: specs of others may be
    missing from it."""
    from vehil.boards import open_board
    from vehil.build.interface import check
    from vehil.estimators import estimators

    with open_board("native") as link:
        problems = check(link, estimators().values(), every_spec_built=every_spec_built)
    if problems:
        raise BuildError(
            "the estimators' C and their Python specs disagree (fix one to match the other):\n  "
            + "\n  ".join(problems)
        )
