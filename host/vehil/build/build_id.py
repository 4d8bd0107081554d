"""The build id every image reports in INFO: the git revision and whether the tree was dirty."""

from __future__ import annotations

import subprocess

from vehil.paths import DATA_ROOT, IN_CHECKOUT


def _git(*args: str) -> str | None:
    if not IN_CHECKOUT:  # an installed vehil: its folder is no repository of its own
        return None
    try:
        out = subprocess.run(
            ["git", *args], cwd=DATA_ROOT, capture_output=True, text=True, check=True
        )
    except (OSError, subprocess.CalledProcessError):
        return None
    return out.stdout.strip()


def build_id_defines() -> list[tuple[str, str]]:
    """VEHIL_BUILD_ID (first 8 hex digits of HEAD, 0 outside a
    checkout) and VEHIL_BUILD_DIRTY."""
    rev = _git("rev-parse", "--short=8", "HEAD") or "0"
    dirty = bool(_git("status", "--porcelain", "--untracked-files=no"))
    return [("VEHIL_BUILD_ID", f"0x{rev}u"), ("VEHIL_BUILD_DIRTY", f"{int(dirty)}u")]
