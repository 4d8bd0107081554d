"""mega16u2://: the Mega's USB bridge model holds board->host bytes for its 4.096 ms timer
(or until more than 96 are waiting) and hands them over in 64-byte packets."""

import statistics

import pytest
import serial

import vehil.transports  # noqa: F401  (registers the URL handlers)
from vehil.link import Link
from vehil.transports import protocol_mega16u2 as bridge


@pytest.fixture
def link(built):  # noqa: ANN001, ANN201
    port = serial.serial_for_url(f"mega16u2://native://{built['native']}", timeout=0.02)
    link = Link(port, timeout_s=1.0)
    link.wait_ready(2.0)
    link.hello()
    yield link
    link.close()


def test_replies_wait_for_the_bridge_timer(link) -> None:
    # The native board answers within microseconds; the bridge holds each reply until
    # its next 4.096 ms tick, about half a period on average.
    rtt = [link.request("PING", payload=b"x" * 16).rtt_s for _ in range(40)]
    assert statistics.median(rtt) > bridge.FLUSH_PERIOD_S / 4


def test_a_long_reply_comes_in_64_byte_packets(link) -> None:
    before = link.port.packets_sent
    reply = link.request("PING", payload=bytes(range(1, 113)))
    assert reply.fields()["payload"] == bytes(range(1, 113))
    assert reply.reply_wire_bytes > bridge.NEAR_FULL  # sent at once, not on the timer
    assert link.port.packets_sent - before == -(-reply.reply_wire_bytes // bridge.PACKET)
