"""SCons build for the offline env: the same sources and flags as atmelavr, Debian's avr-gcc."""

import re
from pathlib import Path

from SCons.Script import Builder, Default, DefaultEnvironment

from vehil.build.ldscript import CODE_SECTION, write_script

env = DefaultEnvironment()
mcu = env.BoardConfig().get("build.mcu")
f_cpu = env.BoardConfig().get("build.f_cpu")

env.Replace(
    AR="avr-gcc-ar",
    AS="avr-gcc",
    CC="avr-gcc",
    CXX="avr-g++",
    OBJCOPY="avr-objcopy",
    RANLIB="avr-gcc-ranlib",
    SIZETOOL="avr-size",
    ARFLAGS=["rc"],
    PROGNAME="firmware",
    PROGSUFFIX=".elf",
    # Flash is code plus initialised data; RAM is everything the linker places in SRAM.
    SIZECHECKCMD="$SIZETOOL -A -d $SOURCES",
    SIZEPROGREGEXP=rf"^(?:\.text|{re.escape(CODE_SECTION)}|\.data|\.bootloader)\s+(\d+).*",
    SIZEDATAREGEXP=r"^(?:\.data|\.bss|\.noinit)\s+(\d+).*",
)
env.Append(
    # -gdwarf-4: line tables for `vehil profile --functions`, the assembly kernels' too (the
    # code is the same without; C sources get it from platformio.ini)
    ASFLAGS=["-mmcu=" + mcu, "-gdwarf-4"],
    CCFLAGS=["-mmcu=" + mcu],
    # .data loaded below 64 KB of flash, where QEMU 7.2 can read it (vehil/build/ldscript.py)
    LINKFLAGS=[
        "-mmcu=" + mcu,
        "-gdwarf-4",
        "-T",
        str(write_script(Path(env.subst("$BUILD_DIR")), mcu)),
    ],
    CPPDEFINES=[("F_CPU", f_cpu)],
    BUILDERS={
        "ElfToHex": Builder(
            action=env.VerboseAction(
                "$OBJCOPY -O ihex -R .eeprom $SOURCES $TARGET", "Building $TARGET"
            ),
            suffix=".hex",
        )
    },
)

elf = env.BuildProgram()
hex_image = env.ElfToHex("$BUILD_DIR/${PROGNAME}", elf)
Default([hex_image])
