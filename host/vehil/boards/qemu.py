"""The QEMU board: qemu-system-avr's mega2560 machine, UART0 on a loopback TCP socket."""

from __future__ import annotations

import shutil
import socket

from vehil.boards.process import BoardProcess, ProcessBoard
from vehil.errors import BoardStartError, BuildMissing
from vehil.paths import FIRMWARE_ELF, FIRMWARE_EV_ELF


class QemuBoard(ProcessBoard):
    name = "qemu"
    elf = FIRMWARE_ELF
    # QEMU's USART takes one byte at a time with back-pressure: 8 frames in flight
    # move ~3x the samples of stop-and-wait (400-580/s against 175/s on `mixed`); with
    # the whole RX buffer in flight it is ~2x slower again.
    max_frames_in_flight = 8
    connect_timeout_s = 10.0  # QEMU listens a moment after it starts

    def start(self) -> str:
        exe = shutil.which("qemu-system-avr")
        if exe is None:
            raise BoardStartError(
                "qemu-system-avr not found: install Debian's qemu-system-misc "
                "(`sudo apt-get install qemu-system-misc`)"
            )
        if not self.elf.exists():
            raise BuildMissing(f"firmware image {self.elf} is missing: run `vehil build`")
        # QEMU serves UART0 on a socket bound here and handed to it listening: a port found
        # free here and bound again by QEMU could be taken in between, by another board
        # starting (two QEMUs on one port: one fails, its host talks to the other's board).
        # nodelay=on: without it Nagle and delayed ACKs cost ~44 ms per exchange.
        # wait=on: the CPU starts only once we are connected, so the ready frame is not lost.
        with socket.create_server(("127.0.0.1", 0)) as listening:
            port = listening.getsockname()[1]
            fd = listening.fileno()
            self.process = BoardProcess(
                [
                    exe,
                    "-M",
                    "mega2560",
                    "-bios",
                    str(self.elf),
                    "-nographic",
                    "-monitor",
                    "none",
                    "-chardev",
                    f"socket,id=uart0,fd={fd},server=on,wait=on,nodelay=on",
                    "-serial",
                    "chardev:uart0",
                ],
                self.name,
                pass_fds=(fd,),
            )
        return f"tcp://127.0.0.1:{port}"  # keeps the boot INFO: see transports/protocol_tcp.py


class QemuEvBoard(QemuBoard):
    """QEMU running the image with seed 001's filters (env offline-ev)."""

    name = "qemu-ev"
    elf = FIRMWARE_EV_ELF
