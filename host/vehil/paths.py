"""Where the project's sources and build products live, and where runs are written."""

import os
from pathlib import Path

# host/vehil/paths.py -> project root (the package is installed editable from host/).
PROJECT_ROOT = Path(__file__).resolve().parents[2]
BUILD_DIR = PROJECT_ROOT / "build"
NATIVE_LIB = BUILD_DIR / "native" / "libvehil.so"
SIMAVR_BRIDGE = PROJECT_ROOT / "sim" / "build" / "vehil-simavr"
FIRMWARE_ELF = PROJECT_ROOT / ".pio" / "build" / "offline" / "firmware.elf"
# The same plus seed 001's filters (env offline-ev): simavr only, see platformio.ini.
FIRMWARE_EV_ELF = PROJECT_ROOT / ".pio" / "build" / "offline-ev" / "firmware.elf"
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
