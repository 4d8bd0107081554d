"""The simavr bridge's VCD trace of UART0 (`--vcd`, sim/vcd_trace.c): when each byte was
written to UDR0 (sent) or read from it (received), in simulated time."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

VCD_NS = 10  # the bridge's VCD timescale


@dataclass(frozen=True)
class UartByte:
    t_ns: int
    value: int  # -1 where the trace has no value


def uart_bytes(vcd: Path) -> tuple[list[UartByte], list[UartByte]]:
    """The bytes sent and the bytes received, each with the time of its strobe."""
    ids: dict[str, str] = {}
    sent: list[UartByte] = []
    received: list[UartByte] = []
    now, tx, rx = 0, 0, 0
    for line in vcd.read_text().splitlines():
        if line.startswith("$var"):
            _, _, _, ident, name, _ = line.split()
            ids[ident] = name
        elif line.startswith("#"):
            now = int(line[1:]) * VCD_NS
        elif line.startswith("b"):
            bits, ident = line.split()
            value = int(bits[1:], 2) if "x" not in bits else -1
            if ids.get(ident) == "uart0_tx":
                tx = value
            elif ids.get(ident) == "uart0_rx":
                rx = value
        elif line[:1] in "01":
            strobe = ids.get(line[1:])
            if strobe == "uart0_tx_strobe":
                sent.append(UartByte(now, tx))
            elif strobe == "uart0_rx_strobe":
                received.append(UartByte(now, rx))
    return sent, received


def frames(stream: list[UartByte]) -> list[list[UartByte]]:
    """The bytes split into frames at each 0x00 delimiter (kept as the frame's last byte)."""
    out: list[list[UartByte]] = [[]]
    for b in stream:
        out[-1].append(b)
        if b.value == 0:
            out.append([])
    return [f for f in out if f]
