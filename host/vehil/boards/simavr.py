"""The simavr boards: sim/'s bridge runs the firmware ELF on a cycle-exact ATmega2560
(`simavr`), or a chip with only the Mega's bootloader that avrdude programs
(`simavr-bootloader`)."""

from __future__ import annotations

import dataclasses
import tempfile
from dataclasses import dataclass
from pathlib import Path

from vehil.boards.base import BoardOptions
from vehil.boards.process import BoardProcess, ProcessBoard
from vehil.errors import BoardTimeout, BuildMissing
from vehil.link import Link
from vehil.paths import (
    FIRMWARE_ELF,
    FIRMWARE_EV_ELF,
    MEGA_BOOTLOADER_HEX,
    SIMAVR_BRIDGE,
    SIMAVR_FLASH_IMAGE,
)

_READY_PREFIX = "vehil-simavr: listening url="


@dataclass(frozen=True)
class SimavrOptions:
    """What only the simavr bridge takes (see sim/options.c)."""

    realtime: bool = False  # held to the chip's real time
    vcd: Path | None = None  # a VCD trace of the UART and the pins
    gdb_port: int | None = None  # simavr's gdb server, waits for gdb
    profile: tuple[str, ...] = ()  # the bridge's --profile options (vehil.fnprofile)
    # UART0 on a loopback TCP socket instead of a pty: a pty hands its bytes on through a
    # kernel worker thread, which a loaded host keeps waiting (round trips' tails).
    tcp: bool = False
    # UART0 on a Unix-domain socket in a folder of its own: as tcp, without the TCP
    # stack (~11 us less a round trip; transports/protocol_unix.py).
    unix: bool = False
    timing: Path | None = None  # with realtime: the bridge's timing log (sim/README.md)
    # UART0 timed as the ATmega2560 does ("chip") or as simavr 1.6 does ("simavr": 11 bits
    # a frame, no TX double buffer), for comparison (sim/README.md, "UART0 timing")
    uart: str = "chip"

    def bridge_options(self) -> list[str]:
        args = ["--realtime"] if self.realtime else []
        if self.tcp:
            args += ["--tcp", "0"]
        if self.vcd:
            args += ["--vcd", str(self.vcd)]
        if self.timing:
            args += ["--timing", str(self.timing)]
        if self.uart != "chip":
            args += ["--uart", self.uart]
        if self.gdb_port is not None:
            args += ["--gdb", str(self.gdb_port)]
        return args + list(self.profile)


class SimavrBoard(ProcessBoard):
    name = "simavr"
    elf = FIRMWARE_ELF
    realtime = False  # a subclass that always runs in real time
    tcp = False  # a subclass that always serves its UART on loopback TCP
    unix = False  # ... or on a Unix-domain socket

    def __init__(self, options: BoardOptions | None = None, simavr: SimavrOptions | None = None):
        super().__init__(options)
        self.simavr = simavr or SimavrOptions()
        self._socket_dir: tempfile.TemporaryDirectory[str] | None = None
        if self.realtime:
            self.simavr = dataclasses.replace(self.simavr, realtime=True)
        if self.tcp:
            self.simavr = dataclasses.replace(self.simavr, tcp=True)
        if self.unix and not self.simavr.tcp:  # options asking for TCP have it
            self.simavr = dataclasses.replace(self.simavr, unix=True)

    def bridge_args(self) -> list[str]:
        """What the bridge runs; checks that it is there."""
        if not self.elf.exists():
            raise BuildMissing(f"firmware image {self.elf} is missing: run `vehil build`")
        return [str(self.elf)]

    def start(self) -> str:
        if not SIMAVR_BRIDGE.exists():
            raise BuildMissing(f"simavr bridge {SIMAVR_BRIDGE} is missing: run `vehil build`")
        argv = [str(SIMAVR_BRIDGE), *self.simavr.bridge_options()]
        if self.simavr.unix:
            self._socket_dir = tempfile.TemporaryDirectory(prefix="vehil-simavr-")
            argv += ["--unix", str(Path(self._socket_dir.name) / "uart0")]
        argv += self.bridge_args()
        self.process = BoardProcess(argv, self.name)
        line = self.process.read_line(timeout_s=10.0)
        if not line.startswith(_READY_PREFIX):
            raise self.process.failure(f"printed {line!r} instead of its URL")
        url = line[len(_READY_PREFIX) :]
        # vehil's tcp:// (transports/protocol_tcp.py): counts the bytes waiting
        return "tcp://" + url.removeprefix("socket://") if url.startswith("socket://") else url

    def stop(self) -> None:
        super().stop()
        if self._socket_dir is not None:
            self._socket_dir.cleanup()
            self._socket_dir = None


class SimavrRealtimeBoard(SimavrBoard):
    """simavr held to the chip's real time, so the UART takes the wire time a Mega's
    does: the board for latency and loop-rate figures (the default runs ahead). On a
    Unix-domain socket, whose bytes a loaded host delays less than a pty's and which
    costs less than loopback TCP (SimavrOptions.tcp, .unix)."""

    name = "simavr-realtime"
    realtime = True
    unix = True


class SimavrMegaBoard(SimavrRealtimeBoard):
    """simavr-realtime behind a model of the Mega's ATmega16U2 USB bridge
    (transports/protocol_mega16u2.py): replies reach the host on the bridge's 4.1 ms
    timer, or sooner past 96 bytes, as on a real Mega."""

    name = "simavr-mega"
    unix = False  # on the pty, whose opening resets the chip as a Mega's DTR does

    def port_url(self, url: str) -> str:
        return super().port_url(f"mega16u2://{url}")


class SimavrEvBoard(SimavrBoard):
    """simavr running the image with seed 001's filters (env offline-ev), which the
    default image leaves out: none keeps a 10 ms step."""

    name = "simavr-ev"
    elf = FIRMWARE_EV_ELF


class SimavrBootloaderBoard(SimavrBoard):
    """A Mega 2560 with nothing but its stk500v2 bootloader: what runs is what avrdude
    wrote. Opening the port resets it into the bootloader, as on the real board; the
    firmware's ready frame comes after the bootloader's ~1 s wait. The flash is kept
    in `flash_image` (None: erased at every start)."""

    name = "simavr-bootloader"
    flashable = True

    bootloader = MEGA_BOOTLOADER_HEX

    def __init__(
        self,
        options: BoardOptions | None = None,
        simavr: SimavrOptions | None = None,
        *,
        flash_image: Path | None = SIMAVR_FLASH_IMAGE,
    ):
        super().__init__(options, simavr)
        self.flash_image = flash_image

    def bridge_args(self) -> list[str]:
        if not self.bootloader.exists():
            raise BuildMissing(
                f"bootloader {self.bootloader} is missing: install Debian's arduino-core-avr "
                "(`sudo apt-get install arduino-core-avr`)"
            )
        args = ["--bootloader", str(self.bootloader)]
        if self.flash_image is not None:
            self.flash_image.parent.mkdir(parents=True, exist_ok=True)
            args += ["--flash-image", str(self.flash_image)]
        return args

    def wait_ready(self, link: Link) -> None:
        try:
            super().wait_ready(link)
        except BoardTimeout as exc:
            raise BoardTimeout(
                f"{exc}\nIs the firmware flashed? `vehil flash --board {self.name}` programs "
                "it through the bootloader."
            ) from None
