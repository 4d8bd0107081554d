"""Where vehil's sources are read from, where its build products are written, and where
runs go.

Two roots, never one:
- DATA_ROOT: vehil's firmware sources, the in-repo PlatformIO platform, the simavr
  bridge's sources, the shipped scenarios. In a checkout, the checkout (the package is
  installed editable from host/); in an installed wheel, the package's `data` folder,
  which is read only.
- CACHE_ROOT: what builds make (the AVR images, the native library, the simavr bridge,
  PlatformIO's own folders): $VEHIL_CACHE, else the current project's `.vehil/` (the
  folder of its vehil.toml), else the checkout (build/ and .pio/ as always), else
  ~/.cache/vehil ($XDG_CACHE_HOME). Never site-packages.
"""

import os
from pathlib import Path

from vehil import project

PACKAGE_DIR = Path(__file__).resolve().parent
_CHECKOUT = PACKAGE_DIR.parents[1]  # host/vehil -> the repository
IN_CHECKOUT = (_CHECKOUT / "firmware" / "lib").is_dir() and (_CHECKOUT / "pyproject.toml").is_file()
DATA_ROOT = _CHECKOUT if IN_CHECKOUT else PACKAGE_DIR / "data"


def _project_file() -> Path | None:
    try:
        return project.find_file()
    except project.ProjectError:
        return None  # said again, with the fix, where the project is read


PROJECT_FILE = _project_file()


def _cache_root() -> Path:
    named = os.environ.get("VEHIL_CACHE")
    if named:
        return Path(named).expanduser().resolve()
    if PROJECT_FILE is not None:
        return PROJECT_FILE.parent.resolve() / ".vehil"
    if IN_CHECKOUT:
        return DATA_ROOT
    home_cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return home_cache / "vehil"


CACHE_ROOT = _cache_root()
BUILD_DIR = CACHE_ROOT / "build"
PIO_WORKSPACE = CACHE_ROOT / ".pio"  # PlatformIO's build and core folders
NATIVE_LIB = BUILD_DIR / "native" / "libvehil.so"
SIMAVR_BRIDGE = BUILD_DIR / "sim" / "vehil-simavr"
IMAGES_DIR = BUILD_DIR / "images"  # images of chosen estimators, one folder each


def image_elf(key: str) -> Path:
    return IMAGES_DIR / key / "pio" / "image" / "firmware.elf"


# The image the boards run: a project's holds what its vehil.toml's `image` names (with the
# project's C); vehil's default env otherwise.
PROJECT_IMAGE = "project"
FIRMWARE_ELF = (
    image_elf(PROJECT_IMAGE)
    if PROJECT_FILE is not None
    else PIO_WORKSPACE / "build" / "offline" / "firmware.elf"
)
# The same plus seed 001's filters (env offline-ev): simavr only, see platformio.ini.
FIRMWARE_EV_ELF = PIO_WORKSPACE / "build" / "offline-ev" / "firmware.elf"
# The Mega 2560's stk500v2 bootloader, from Debian's arduino-core-avr.
MEGA_BOOTLOADER_HEX = Path(
    "/usr/share/arduino/hardware/arduino/avr/bootloaders/stk500v2/stk500boot_v2_mega2560.hex"
)
# The simavr-bootloader board's flash, kept between runs.
SIMAVR_FLASH_IMAGE = BUILD_DIR / "simavr-bootloader" / "flash.bin"
FLASH_DIR = BUILD_DIR / "flash"  # Intel HEX images made for avrdude


def runs_dir() -> Path:
    """Where runs and profiles go when no folder is given: `runs/` under the current
    directory, or $VEHIL_RUNS (the test suite points it at a temporary folder)."""
    return Path(os.environ.get("VEHIL_RUNS", "runs"))
