"""UART0's timing on the simavr board against the chip's: the bit time at every standard
rate SET_BAUD accepts, and a transmitter that sends bytes back to back.

simavr fixes a UART's byte time when UBRR0 is written, from U2X0 as it is then, so an
init that writes them in the other order runs at half the requested baud on simavr and
at the right one on the chip. The bridge times UART0 as the chip does (sim/README.md,
"UART0 timing"): a 10-bit 8N1 frame, and a double-buffered transmitter. Its VCD trace
timestamps every byte as it enters the shift register, in simulated time; inside a reply
frame the TX interrupt refills UDR0 as soon as UDRE0 is set, so a frame's bytes follow
each other one frame time apart (except where the transmitter waits for the next COBS
block to be released).
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
BITS_PER_BYTE = 10  # 8N1: start, 8 data bits, stop
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


def test_bytes_leave_back_to_back_at_2_mbaud(built, tmp_path) -> None:
    """A burst of replies at 2 Mbaud: each byte the firmware writes into UDR0 as soon as
    UDRE0 is set starts the moment the byte before it has left (the shift register takes
    it from UDR0 then), so the bytes of a reply are one 10-bit frame apart. A transmitter
    that only sets UDRE0 once its byte is out (simavr's own) adds the TX interrupt's
    response to every byte. The longer gaps are the firmware's: bytes not yet released."""
    baud, n = 2_000_000, 16
    frame_ns = BITS_PER_BYTE * 1e9 / baud
    late_ns = 5e9 / F_CPU  # the longest instruction: 5 cycles
    vcd = tmp_path / "uart.vcd"
    with open_board("simavr", BoardOptions(timeout_s=5.0), SimavrOptions(vcd=vcd)) as link:
        link.set_baud(baud)
        first = link.stats()["tx_frames"] + 1  # after the STATS reply
        with link.corked():  # the burst in one write: the replies queue up on the board
            pings = (("PING", {"payload": bytes([1 + i]) * 16}) for i in range(n))
            assert len(list(link.pipeline(pings, window=n))) == n
    replies = frames(uart_bytes(vcd)[0])[first : first + n]
    gaps = [b.t_ns - a.t_ns for f in replies for a, b in zip(f, f[1:], strict=False)]
    # a byte's timestamp is the first instruction boundary at or after its start
    back_to_back = [g for g in gaps if abs(g - frame_ns) <= late_ns]
    print(f"\n{len(back_to_back)} of {len(gaps)} bytes one frame after the one before")
    assert min(gaps) >= frame_ns - late_ns  # never two bytes on the line at once
    # most of them (simavr's own transmitter: none, each byte 11 bits and a response late);
    # how many depends on how the firmware releases a reply's bytes
    assert len(back_to_back) >= 0.5 * len(gaps)


def test_bytes_arrive_no_faster_than_the_line_at_2_mbaud(built, tmp_path) -> None:
    """A burst of requests written at once reaches the firmware one 10-bit frame a byte, as
    bytes sent back to back would on the wire: over any 24 bytes of it, the firmware reads
    the last no sooner than 21 frames after the first (it may read up to three the
    receiver holds at once). simavr's own receiver queues what the client sent and lets
    the firmware read two a frame time: 26-byte requests came in within ~1,300 cycles,
    0.6 of a frame a byte. The firmware keeps up: no byte lost."""
    baud, n, span = 2_000_000, 8, 24
    frame_ns = BITS_PER_BYTE * 1e9 / baud
    late_ns = 5e9 / F_CPU  # a timestamp is the first instruction boundary after its event
    vcd = tmp_path / "uart.vcd"
    with open_board("simavr", BoardOptions(timeout_s=5.0), SimavrOptions(vcd=vcd)) as link:
        link.set_baud(baud)
        before = link.stats()
        with link.corked():  # the burst in one write
            pings = (("PING", {"payload": bytes([1 + i]) * 16}) for i in range(n))
            assert len(list(link.pipeline(pings, window=n))) == n
        after = link.stats()
    received = uart_bytes(vcd)[1]
    burst = [b.t_ns for f in frames(received)[-n - 1 : -1] for b in f]  # before GET_STATS
    assert len(burst) >= n * len(frame.encode(0x02, 1, bytes(16)))
    spans = [burst[i + span] - burst[i] for i in range(len(burst) - span)]
    print(f"\n{span} bytes in at least {min(spans) / frame_ns:.2f} frames")
    assert min(spans) >= (span - 3) * frame_ns - late_ns
    assert after["overruns"] == before["overruns"]
