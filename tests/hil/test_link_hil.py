"""The firmware on virtual boards (simavr, QEMU) over a real serial link.

These are the product's regression: the real avr-gcc image, the real
simulators, bytes through a socket, every reply checked.
"""

import contextlib
import os
import random
import struct
import threading
import time

import pytest

from vehil.boards import BoardOptions, SimavrOptions, make_board, open_board
from vehil.build.budget import DEEPEST_SHIPPED_STACK, USER_ESTIMATOR_RAM
from vehil.errors import BoardError
from vehil.estimators import acc_kf
from vehil.ping import run_ping
from vehil.protocol import frame as framing
from vehil.protocol.schema import SCHEMA

pytestmark = pytest.mark.hil

BOARDS = ["simavr", "qemu"]


@pytest.fixture(scope="module", params=BOARDS)
def link(request, built):  # noqa: ANN001, ANN201
    with open_board(request.param, BoardOptions(timeout_s=3.0)) as link:
        link.board_name = request.param
        yield link


def test_board_announces_itself_with_its_clock_and_estimators(link) -> None:
    info = link.info
    assert info.f_cpu == 16_000_000
    assert info.fields["baud"] == 1_000_000
    assert info.fields["boot_count"] >= 1
    # The RAM budget (README, "RAM for your estimator"): what is free at boot covers the
    # deepest shipped estimator's stack and leaves USER_ESTIMATOR_RAM for a user's.
    assert info.fields["free_ram"] >= DEEPEST_SHIPPED_STACK + USER_ESTIMATOR_RAM
    assert "passthrough" in [e.name for e in info.estimators]


def test_ten_thousand_pings_of_random_sizes_are_all_echoed(link) -> None:
    # QEMU moves about 250 frames/s whatever the window, and with many long frames in
    # flight it sometimes slows to a crawl: it gets fewer, one at a time.
    count, window = (10_000, 8) if link.board_name == "simavr" else (500, 1)
    summary = run_ping(link, count=count, size=None, window=window, seed=1)
    assert len(summary.rtt_s) == count  # run_ping raises on any loss or wrong echo
    stats = link.stats()
    assert (stats["crc_errors"], stats["cobs_errors"], stats["overruns"]) == (0, 0, 0)


def test_the_boards_clock_counts_on_past_every_timer_overflow(link) -> None:
    """Timer1 and its overflow count (cycles.h, both in assembly): PONG timestamps rise
    across 16-bit overflows and the count's carry into its high byte at 2**24 cycles."""
    if link.board_name != "simavr":
        pytest.skip("QEMU's emulated timer may step back (dispatch.c's steps read it as 0)")
    stamps = [link.request("PING", payload=b"").fields()["timestamp"]]
    target = (stamps[0] // 2**24 + 1) * 2**24 + 2**17  # past the next carry
    deadline = time.monotonic() + 30  # simavr runs the idle board ~1 s of its time in < 5 s
    while stamps[-1] < target and time.monotonic() < deadline:
        stamps.append(link.request("PING", payload=b"").fields()["timestamp"])
    steps = [b - a for a, b in zip(stamps, stamps[1:], strict=False)]
    assert stamps[-1] >= target and min(steps) > 0


def test_config_with_a_bad_estimator_id_is_an_error_and_the_link_goes_on(link) -> None:
    with pytest.raises(BoardError, match="UNKNOWN_ESTIMATOR"):
        link.request("CONFIG", estimator=250, mode=SCHEMA.mode["F32"], offset=0, params=b"")
    assert link.request("PING", payload=b"still here").fields()["payload"] == b"still here"


def test_passthrough_returns_ten_thousand_samples_in_order(link) -> None:
    link.configure("passthrough", "F32")
    rng = random.Random(2)
    count = 10_000 if link.board_name == "simavr" else 1_000  # QEMU: ~250 frames/s
    inputs = [struct.pack("<4f", *(rng.uniform(-1e3, 1e3) for _ in range(4))) for _ in range(count)]
    replies = list(link.pipeline(("SAMPLE", {"inputs": x}) for x in inputs))
    assert [r.fields()["outputs"] for r in replies] == inputs
    cycles = [r.fields()["cycles"] for r in replies]
    if link.board_name == "simavr":  # cycle-exact; QEMU's Timer1 follows the host's clock
        assert min(cycles) > 0 and max(cycles) < 2_000  # a 16-byte copy, interrupts included


def test_stack_high_water_mark_is_reported_and_below_the_stack(link) -> None:
    stats = link.stats()
    assert 0 < stats["stack_unused"] < stats["stack_size"]


@pytest.mark.parametrize("baud", [115_200, 250_000, 500_000, 2_000_000, 1_000_000])
def test_baud_rate_switches_at_run_time(link, baud: int) -> None:
    link.set_baud(baud)
    assert link.hello().fields["baud"] == baud
    run_ping(link, count=50, size=16)


def test_unreachable_baud_rate_is_refused_with_its_reason(link) -> None:
    with pytest.raises(BoardError, match="BAD_BAUD.*unreachable"):
        link.request("SET_BAUD", baud=300)
    with pytest.raises(BoardError, match=r"BAD_BAUD.*error 8\.51 %"):
        link.request("SET_BAUD", baud=921_600)  # nearest is 1,000,000: +8.5 %


def test_reboot_request_restarts_the_board_and_it_announces_itself(link) -> None:
    before = link.info.fields["boot_count"]
    link.request("RESET", what=SCHEMA.reset_what["REBOOT"])
    ready = link.wait_ready(5.0)
    assert ready["boot_count"] == before + 1
    assert ready["reset_cause"] == SCHEMA.reset_cause["SOFTWARE"]
    assert link.hello().fields["baud"] == 1_000_000


def test_a_hung_board_is_brought_back_by_its_watchdog(link) -> None:
    if link.board_name != "simavr":
        pytest.skip("QEMU's mega2560 has no watchdog: a hung board stays hung")
    before = link.info.fields["boot_count"]
    # hang, interrupts off, the watchdog not fed
    link.request("RESET", what=SCHEMA.reset_what["HANG"])
    ready = link.wait_ready(5.0)  # WDTO_1S of simulated time
    assert ready["reset_cause"] == SCHEMA.reset_cause["WATCHDOG"]
    assert ready["boot_count"] == before + 1
    assert link.request("PING", payload=b"back").fields()["payload"] == b"back"


def test_a_profile_sweep_point_measures_without_loss(link) -> None:
    from vehil.profile import sweep

    (point,) = sweep(link, (250_000,), count=40, sizes=(16,), windows=(1, 8))
    (lat,) = point["latency"]
    assert lat["rtt_ms"]["p50"] > 0 and lat["crc_errors"] == lat["overruns"] == 0
    assert [tp["window"] for tp in point["throughput"]] == [1, 8]
    if link.board_name == "simavr":  # QEMU keeps one frame in flight: windows change nothing
        # By the board's clock, which the host's load cannot slow (wall-clock frames/s was
        # moved by it), and the median PONG interval: a stall of the host's leaves the board
        # idle, and a few of them in window 8's 40 exchanges could outweigh the overlap in
        # the span's mean. At 250 kbaud one exchange at a time is its 56 bytes on the wire,
        # 2.24 ms; eight in flight overlap a request's bytes in with a reply's out.
        one, eight = (tp["board_interval_ms"]["p50"] for tp in point["throughput"])
        assert eight < one
    assert link.info.fields["probe_cycles"] > 0


@pytest.mark.parametrize(
    ("transport", "module"),
    [(SimavrOptions(unix=True), "protocol_unix"), (SimavrOptions(tcp=True), "protocol_tcp")],
)
def test_simavr_realtime_serves_its_uart_on_a_socket(built, transport, module) -> None:  # noqa: ANN001
    """simavr-realtime's transports, a Unix-domain socket (its own) and loopback TCP: the
    boot INFO kept, and every PING echoed in order at the chip's pace."""
    board = make_board("simavr-realtime", BoardOptions(timeout_s=3.0), transport)
    with board.session() as link:
        assert type(link.port).__module__ == f"vehil.transports.{module}"
        assert link.info.fields["baud"] == 1_000_000
        s = run_ping(link, count=50, size=16, window=1)  # raises on a lost or wrong reply
        assert len(s.rtt_s) == 50
        # by the chip's clock no exchange is shorter than its bytes' time on the wire
        assert s.board_interval_s.min() >= s.wire_bytes * 10 / 1_000_000


def test_simavr_realtime_logs_where_each_exchange_went_and_runs_above_a_real_time_host(
    built,  # noqa: ANN001
    tmp_path,  # noqa: ANN001
) -> None:
    """--timing: one `in` and one `out` line for each stop-and-wait PING, in order, on the
    host's clock; started by a thread under SCHED_RR 10, the bridge runs at 11."""
    board = make_board(
        "simavr-realtime", BoardOptions(timeout_s=3.0), SimavrOptions(timing=tmp_path / "t")
    )
    seen: dict = {}

    def run() -> None:
        with contextlib.suppress(PermissionError, AttributeError):  # the log is checked anyway
            os.sched_setscheduler(0, os.SCHED_RR, os.sched_param(10))
        with board.session() as link:
            seen["bridge"] = os.sched_getparam(board.process.proc.pid).sched_priority
            seen["ours"] = os.sched_getparam(0).sched_priority
            pings = [("PING", {"payload": b"x" * 16})] * 20
            seen["sent"] = [r.sent_at for r in link.pipeline(pings, window=1)]

    t = threading.Thread(target=run)
    t.start()
    t.join()
    if seen["ours"] == 10:
        assert seen["bridge"] == 11
    events = [line.split() for line in (tmp_path / "t").read_text().splitlines()]
    ins = [[int(x) for x in e[1:]] for e in events if e[0] == "in"]
    outs = [[int(x) for x in e[1:]] for e in events if e[0] == "out"]
    # the last 20 exchanges: a request's bytes read after it was sent, fed after they were
    # read, its reply written after its bytes were fed, and the wire's time at least apart
    for sent, (read, feed, c_in, _, n), (start, end, c_out, _, _) in zip(
        seen["sent"], ins[-20:], outs[-20:], strict=True
    ):
        assert n == len(framing.encode(0, 1, bytes(16)))
        assert read <= feed <= start <= end
        assert abs(read - sent * 1e9) < 0.1e9
        assert c_out - c_in >= 16 * 10 * n  # 10 bits a byte at 1 Mbaud, 16 cycles a µs


def test_the_bridge_serves_no_socket_over_a_file_that_is_not_one(built, tmp_path) -> None:  # noqa: ANN001
    import subprocess

    from vehil.paths import FIRMWARE_ELF, SIMAVR_BRIDGE

    kept = tmp_path / "uart0"
    kept.write_text("a user's file")
    proc = subprocess.run(
        [str(SIMAVR_BRIDGE), "--unix", str(kept), str(FIRMWARE_ELF)],
        capture_output=True,
        text=True,
        timeout=20,
    )
    assert proc.returncode == 1
    assert "exists and is not a socket" in proc.stderr
    assert kept.read_text() == "a user's file"


def test_pings_streamed_between_steps_at_2_mbaud_lose_no_byte_at_a_mode_switch(built) -> None:  # noqa: ANN001
    """At 2 Mbaud the frame loops serve the UART with interrupts off and a step runs with
    them on (firmware/src/uart.h): every frame switches modes four times or more. Bursts
    of PINGs, each with its own payload, between SAMPLEs of ACC KF FIXED (~3.9 k cycles
    a step: ~48 bytes come in meanwhile, through the receive interrupt), sent with no
    retries: a byte lost or taken twice at a switch fails a frame's CRC, an echo or a
    RESULT, and every RESULT matches the native build's bit for bit."""
    rng = random.Random(18)
    inputs = [struct.pack("<4f", *(rng.uniform(-3, 3) for _ in range(4))) for _ in range(300)]
    params = acc_kf.SPEC.encode_params(acc_kf.spec_defaults(), "FIXED")
    requests: list[tuple[str, dict]] = []
    for x in inputs:
        requests += [("PING", {"payload": rng.randbytes(rng.randint(0, 48))}) for _ in range(4)]
        requests.append(("SAMPLE", {"inputs": x}))
    with open_board("native", BoardOptions()) as native:
        native.configure("acc_kf", "FIXED", params)
        samples = native.pipeline(("SAMPLE", {"inputs": x}) for x in inputs)
        expected = [r.fields()["outputs"] for r in samples]
    with open_board("simavr", BoardOptions(timeout_s=3.0)) as link:
        link.set_baud(2_000_000)
        link.configure("acc_kf", "FIXED", params)
        before = link.stats()
        replies = list(link.pipeline(requests, retries=0))
        after = link.stats()
    got = [r.fields() for r in replies]
    for (name, fields), reply in zip(requests, got, strict=True):
        if name == "PING":
            assert reply["payload"] == fields["payload"]
    assert [g["outputs"] for g in got[4::5]] == expected
    for counter in ("crc_errors", "cobs_errors", "overruns"):
        assert after[counter] == before[counter], counter


def _hostile_stream(rng: random.Random) -> list[bytes]:
    """PINGs, good and damaged, among garbage: each piece a write of its own."""
    ping = SCHEMA.messages["PING"].type
    room = SCHEMA.max_body - 4  # a PONG's timestamp, then the echo
    pieces: list[bytes] = []
    for i in range(60):
        payload = bytes(
            rng.choice((0, 1, 0xFF, rng.randrange(256))) for _ in range(rng.randint(0, room))
        )
        good = framing.encode(ping, 1 + i, payload)
        kind = rng.randrange(7)
        if kind == 0:  # a byte flipped
            k = rng.randrange(len(good) - 1)
            good = good[:k] + bytes([good[k] ^ (1 << rng.randrange(8))]) + good[k + 1 :]
        elif kind == 1:  # cut short: the next delimiter ends it
            good = good[: rng.randrange(1, len(good) - 1)] + b"\x00"
        elif kind == 2:  # garbage before it, zeros and code bytes among it
            good = bytes(rng.choice((0, 0xFF, rng.randrange(256))) for _ in range(40)) + good
        elif kind == 3:  # a block's code byte pointing past the delimiter
            good = b"\xff" + bytes(rng.randrange(1, 256) for _ in range(20)) + b"\x00" + good
        pieces.append(good)
    pieces.append(b"\x01" * 300 + b"\x00")  # oversize: zeros, one a code byte
    pieces.append(b"\x00\x00" + framing.encode(ping, 99, bytes(range(1, room + 1))))  # the largest
    return pieces


def _replies(link, pieces: list[bytes], quiet_s: float) -> list[tuple[str, int, bytes]]:  # noqa: ANN001
    """What the board answers to each piece, read until it falls quiet."""
    ping = SCHEMA.messages["PING"].type
    decoder = framing.StreamDecoder(answers=lambda seq: ping if seq else 0)
    got: list[tuple[str, int, bytes]] = []
    for piece in pieces:
        link.port.write(piece)
        quiet = time.perf_counter() + quiet_s
        while time.perf_counter() < quiet:
            data = link.port.read(max(1, link.port.in_waiting))
            for f in decoder.feed(data):
                got.append((f.name, f.seq, f.body[4:] if f.name == "PONG" else f.body))
                quiet = time.perf_counter() + quiet_s
    assert decoder.bad_frames == 0
    return got


@pytest.mark.parametrize("baud", [1_000_000, 2_000_000])
def test_the_receiver_takes_a_hostile_stream_as_its_c_twin_does(built, baud) -> None:  # noqa: ANN001
    """firmware/src/frame_avr.S's receiver against proto/frame.c's on the host: good,
    damaged and oversize frames among garbage, each piece written alone (no overrun),
    at 1 Mbaud (the receive interrupt fills the ring) and 2 Mbaud (the receiver's own
    service points do): the same replies and the same error counts."""
    pieces = _hostile_stream(random.Random(baud))
    counts = {}
    replies = {}
    for name in ("native", "simavr"):
        with open_board(name, BoardOptions(timeout_s=3.0)) as link:
            if name == "simavr":
                link.set_baud(baud)
                link.port.timeout = 0.02
            before = link.stats()
            replies[name] = _replies(link, pieces, 0.25 if name == "simavr" else 0.02)
            after = link.stats()
        counts[name] = {
            k: after[k] - before[k] for k in ("crc_errors", "cobs_errors", "oversize", "overruns")
        }
    assert replies["simavr"] == replies["native"]
    assert counts["simavr"] == counts["native"]
    assert counts["simavr"]["overruns"] == 0
    assert all(counts["simavr"][k] > 0 for k in ("crc_errors", "cobs_errors", "oversize"))
    assert sum(r[0] == "PONG" for r in replies["simavr"]) > 10
