"""Where the project's sources and build products live."""

from pathlib import Path

# host/vehil/paths.py -> project root (the package is installed editable from host/).
PROJECT_ROOT = Path(__file__).resolve().parents[2]
BUILD_DIR = PROJECT_ROOT / "build"
NATIVE_LIB = BUILD_DIR / "native" / "libvehil.so"
SIMAVR_BRIDGE = PROJECT_ROOT / "sim" / "build" / "vehil-simavr"
FIRMWARE_ELF = PROJECT_ROOT / ".pio" / "build" / "offline" / "firmware.elf"
