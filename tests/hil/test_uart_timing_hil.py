"""The bit time simavr really gives the UART, at every standard rate SET_BAUD accepts.

simavr fixes a UART's byte time when UBRR0 is written, from U2X0 as it is then, so an
init that writes them in the other order runs at half the requested baud on simavr and
at the right one on the chip. The bridge's VCD trace timestamps every byte written to
UDR0 in simulated time; inside a reply frame the TX interrupt refills UDR0 as soon as
it empties, so the spacing of a frame's bytes is simavr's byte time (except where the
transmitter waits for the next COBS block to be released).
"""

from __future__ import annotations

import statistics

import pytest

from vehil.boards import BoardOptions, SimavrOptions, open_board
from vehil.errors import BoardError
from vehil.protocol import frame
from vehil.vcd import frames, uart_bytes

pytestmark = pytest.mark.hil

F_CPU = 16_000_000
STANDARD_BAUDS = (
    9600,
    14400,
    19200,
    28800,
    38400,
    57600,
    76800,
    115200,
    230400,
    250000,  # fmt: skip
    460800,
    500000,
    921600,
    1_000_000,
    2_000_000,
)
BITS_PER_BYTE = 11  # simavr counts a parity bit in 8N1 (see sim/README.md)
PINGS = 3
PAYLOAD = bytes(range(1, 49))
PONG_WIRE = len(frame.encode(0x82, 1, bytes(4) + PAYLOAD))  # with its delimiter


def test_simavr_bit_time_is_the_requested_baud_at_every_accepted_rate(built, tmp_path) -> None:
    vcd = tmp_path / "uart.vcd"
    first_pong: dict[int, int] = {}  # baud -> index of its first PONG among the board's frames
    with open_board("simavr", BoardOptions(timeout_s=5.0), SimavrOptions(vcd=vcd)) as link:
        for baud in STANDARD_BAUDS:
            sent = link.stats()["tx_frames"]  # frames before this STATS reply
            try:
                link.set_baud(baud)
            except BoardError as exc:
                assert exc.code == "BAD_BAUD", exc
                continue
            first_pong[baud] = sent + 2  # after the STATS reply and SET_BAUD's ACK
            for _ in range(PINGS):
                link.request("PING", payload=PAYLOAD)
    replies = frames(uart_bytes(vcd)[0])
    lines, measured = [], []
    for baud, first in first_pong.items():
        pongs = [[b.t_ns for b in f] for f in replies[first : first + PINGS]]
        assert all(len(f) == PONG_WIRE for f in pongs)
        # Over eight bytes, which evens out the trace's 10 ns steps; the median leaves out
        # the windows where the transmitter waited for the encoder to release a COBS block.
        byte_ns = statistics.median((f[i + 8] - f[i]) / 8 for f in pongs for i in range(len(f) - 8))
        bit_s = byte_ns / BITS_PER_BYTE * 1e-9
        ubrr = round(F_CPU / (8 * baud)) - 1  # U2X: a bit is 8 (UBRR + 1) cycles
        chip_bit_s = 8 * (ubrr + 1) / F_CPU
        measured.append((baud, bit_s, chip_bit_s))
        lines.append(
            f"{baud:>9} baud: bit {bit_s * 1e6:8.3f} us, chip {chip_bit_s * 1e6:8.3f} us, "
            f"{bit_s * baud:.4f} x requested"
        )
    print("\n" + "\n".join(lines))
    for baud, bit_s, chip_bit_s in measured:
        assert bit_s == pytest.approx(chip_bit_s, rel=0.01), f"{baud} baud"
        assert bit_s * baud == pytest.approx(1.0, abs=0.04), f"{baud} baud"  # SET_BAUD's limit
    assert {115200, 250000, 500000, 1_000_000, 2_000_000} <= set(first_pong)
