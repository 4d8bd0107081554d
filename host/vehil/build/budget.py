"""The RAM and flash an image leaves for a user's estimators (README, "RAM for your
estimator"): static RAM and flash from the ELF's sections, the stack the deepest
shipped estimator needs as measured, and what is left."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from elftools.elf.elffile import ELFFile

RAM_BYTES = 8192  # ATmega2560 SRAM
FLASH_BYTES = 253_952  # 256 KB less the 8 KB bootloader section
# Stack high-water (STATS) of the deepest shipped estimator's run on simavr, rounded up:
# STLQF FIXED, 1,076 B in stlqf/mass-step-fixed (link, interrupts and step included).
DEEPEST_SHIPPED_STACK = 1_100
USER_ESTIMATOR_RAM = 4_096  # the budget promised to a user's estimator: state and stack

_RAM_SECTIONS = (".data", ".bss", ".noinit")
_FLASH_SECTIONS = (".text", ".code", ".data")


@dataclass(frozen=True)
class Budget:
    static_ram: int
    flash: int

    @property
    def ram_left(self) -> int:
        """RAM neither static nor needed by the deepest shipped estimator's stack."""
        return RAM_BYTES - self.static_ram - DEEPEST_SHIPPED_STACK

    @property
    def flash_left(self) -> int:
        return FLASH_BYTES - self.flash

    def summary(self) -> str:
        return (
            f"static RAM {self.static_ram} B, deepest shipped stack {DEEPEST_SHIPPED_STACK} B: "
            f"{self.ram_left} B of RAM left for your estimators (budget "
            f"{USER_ESTIMATOR_RAM} B); flash {self.flash} B, {self.flash_left} B left"
        )


def budget(elf: Path) -> Budget:
    with elf.open("rb") as f:
        sizes = {s.name: s["sh_size"] for s in ELFFile(f).iter_sections()}
    return Budget(
        static_ram=sum(sizes.get(n, 0) for n in _RAM_SECTIONS),
        flash=sum(sizes.get(n, 0) for n in _FLASH_SECTIONS),
    )
