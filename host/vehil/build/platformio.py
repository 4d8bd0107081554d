"""The firmware image, built by PlatformIO with no network.

PlatformIO runs every build through its `tool-scons` package, which it would
download. We install it from platform/tool-scons (a shim over the pip `scons`
package) into a core dir of our own, with the metadata PlatformIO looks up
(owner `platformio`, the range its dependencies.py pins), before each build.
"""

from __future__ import annotations

import configparser
import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

from platformio.dependencies import get_core_dependencies

from vehil.build import vendored
from vehil.errors import BuildError
from vehil.paths import DATA_ROOT, PIO_WORKSPACE, image_elf

CORE_DIR = PIO_WORKSPACE / "core"
_TOOL_SCONS_SOURCE = DATA_ROOT / "platform" / "tool-scons"


def firmware_elf(env: str = "offline") -> Path:
    return PIO_WORKSPACE / "build" / env / "firmware.elf"


def install_tool_scons(core_dir: Path = CORE_DIR) -> Path:
    target = core_dir / "packages" / "tool-scons"
    manifest = json.loads((_TOOL_SCONS_SOURCE / "package.json").read_text())
    meta = {
        "type": "tool",
        "name": "tool-scons",
        "version": manifest["version"],
        "spec": {
            "owner": "platformio",
            "id": None,
            "name": "tool-scons",
            "requirements": get_core_dependencies()["tool-scons"],
            "uri": None,
        },
    }
    target.mkdir(parents=True, exist_ok=True)
    for name in ("package.json", "scons.py"):
        shutil.copy2(_TOOL_SCONS_SOURCE / name, target / name)
    (target / ".piopm").write_text(json.dumps(meta))
    return target


def check_boot_baud(baud: int) -> None:
    """Refuses a boot rate the UART cannot make from 16 MHz within the firmware's 4 %."""
    from vehil.profile import uart_setting

    s = uart_setting(baud)
    if s.ubrr > 4095:
        what = "below 489 baud, the slowest the UART's divider makes"
    elif abs(s.error_pct) > 4.0:
        what = f"the UART makes {s.actual:,.0f} ({s.error_pct:+.1f} %), past the 4 % a link takes"
    else:
        return
    raise BuildError(
        f"--boot-baud {baud}: {what} from 16 MHz; give a rate it makes, such as 57600, "
        "115200, 230400, 250000 or 500000"
    )


def _environment(boot_baud: int | None = None) -> dict[str, str]:
    """PlatformIO's folders in vehil's cache (vehil/paths.py): vehil's own sources may be
    an installed package's, which nothing writes into. A boot rate goes to the C (the
    UART's first setting) and into the ELF as the symbol vehil_boot_baud, which the host
    reads to open the link at it (boards/base.py, image_boot_baud)."""
    env = dict(os.environ)
    env.update(
        PLATFORMIO_CORE_DIR=str(CORE_DIR),
        PLATFORMIO_WORKSPACE_DIR=str(PIO_WORKSPACE),
        PLATFORMIO_SETTING_ENABLE_TELEMETRY="No",
        PLATFORMIO_SETTING_CHECK_PLATFORMIO_INTERVAL="36500",
        PLATFORMIO_DISABLE_PROGRESSBAR="true",
        PLATFORMIO_NO_ANSI="true",
    )
    env.pop("PLATFORMIO_BUILD_FLAGS", None)
    if boot_baud is not None:
        check_boot_baud(boot_baud)
        env["PLATFORMIO_BUILD_FLAGS"] = (
            f"-DVEHIL_BOOT_BAUD={boot_baud}UL -Wl,--defsym=vehil_boot_baud={boot_baud}"
        )
    return env


_SECTION = re.compile(r"^\s*\d+\s+(\S+)\s+([0-9a-f]+)\s+[0-9a-f]+\s+([0-9a-f]+)\s")


def check_data_in_low_flash(elf: Path) -> None:
    """The initialised RAM data must load from below 64 KB of flash: avr-libc's start-up
    copies it with ELPM, and QEMU 7.2 (Debian 12) ignores RAMPZ in ELPM (fixed in 8.0 by
    "target/avr: fix long address calculation"), so above 64 KB it reads the wrong bytes
    and every initialised variable starts wrong on the qemu board."""
    out = subprocess.run(["avr-objdump", "-h", str(elf)], capture_output=True, text=True)
    for line in out.stdout.splitlines():
        m = _SECTION.match(line)
        if m and m.group(1) == ".data":
            end = int(m.group(3), 16) + int(m.group(2), 16)
            if end > 0x10000:
                raise BuildError(
                    f"{elf}: .data loads from flash up to 0x{end:x}, past 64 KB, where QEMU "
                    "7.2's ELPM cannot read it (it ignores RAMPZ): the linker script "
                    "(vehil/build/ldscript.py) should have loaded it low; was it used? "
                    '(README, "What runs on the board")'
                )
            return
    raise BuildError(f"{elf}: no .data in `avr-objdump -h` output:\n{out.stdout}{out.stderr}")


def default_estimators() -> str:
    """platformio.ini's custom_estimators for the default image."""
    ini = configparser.ConfigParser(interpolation=None, inline_comment_prefixes=(";",))
    ini.read(DATA_ROOT / "platformio.ini")
    return ini["env"].get("custom_estimators", "all")


def build_image(
    estimators: str,
    c_sources: Sequence[Path] = (),
    *,
    key: str | None = None,
    boot_baud: int | None = None,
    verbose: bool = False,
) -> Path:
    """The default env's image holding `estimators` (registry.select's words: `all -manf`,
    `manf acc_kf`), with the C in the `c_sources` folders (a project's) compiled in, built
    in its own folder under build/images (incrementally, and leaving the envs' builds
    alone), booting at `boot_baud` (None: the firmware's default); returns its ELF."""
    if key is None:
        key = re.sub(r"[^a-z0-9_]+", "-", estimators.lower()).strip("-") or "all"
        key += f"-boot{boot_baud}" if boot_baud is not None else ""
    elf = image_elf(key)
    folder = elf.parents[2]
    folder.mkdir(parents=True, exist_ok=True)
    ini = folder / "platformio.ini"
    base = (DATA_ROOT / "platformio.ini").read_text()
    text = (
        f"{base}\n[env:image]\nextends = env:offline\ncustom_estimators = {estimators}\n"
        f"custom_c_sources = {' '.join(map(str, c_sources))}\n"
        f"custom_vendored = {' '.join(map(str, vendored.roots()))}\n"
    )
    if not ini.exists() or ini.read_text() != text:
        ini.write_text(text)
    install_tool_scons()
    cmd = [sys.executable, "-m", "platformio", "run", "-d", str(DATA_ROOT), "-c", str(ini)]
    env = {**_environment(boot_baud), "PLATFORMIO_BUILD_DIR": str(folder / "pio")}
    proc = subprocess.run([*cmd, "-e", "image"], env=env, capture_output=True, text=True)
    if verbose or proc.returncode != 0:
        tail = "\n".join((proc.stdout + proc.stderr).strip().splitlines()[-30:])
        if proc.returncode != 0:
            raise BuildError(f"image build failed ({estimators}):\n{tail}")
        print(tail)
    check_data_in_low_flash(elf)
    return elf


_SIZE_LINE = re.compile(r"^(RAM|Flash):\s+\[.*\]\s+(.*)$")


def build_firmware(
    env: str = "offline", *, boot_baud: int | None = None, verbose: bool = False
) -> Path:
    """Runs `pio run -e ENV` (the UART booting at `boot_baud`, None: the firmware's
    default); prints PlatformIO's RAM/Flash lines; returns the ELF."""
    install_tool_scons()
    cmd = [sys.executable, "-m", "platformio", "run", "-d", str(DATA_ROOT), "-e", env]
    if verbose:
        cmd.append("-v")
    proc = subprocess.run(cmd, env=_environment(boot_baud), capture_output=True, text=True)
    output = proc.stdout + proc.stderr
    if verbose:
        print(output)
    if proc.returncode != 0:
        tail = "\n".join(output.strip().splitlines()[-30:])
        raise BuildError(f"firmware build failed (`{' '.join(cmd[1:])}`):\n{tail}")
    for line in output.splitlines():
        m = _SIZE_LINE.match(line.strip())
        if m and not verbose:
            print(f"firmware {m.group(1)}: {m.group(2)}")
    if env.startswith("offline"):  # the images the qemu boards run
        check_data_in_low_flash(firmware_elf(env))
    return firmware_elf(env)
