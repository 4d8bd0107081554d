"""The C frame codec (firmware/lib/proto, host build) and the Python one agree.

The C side is reached through the native board: its replies are encoded by the C
encoder (COBS and CRC-32C into the TX buffer byte by byte) and must decode in Python;
the requests Python encodes, corrupted or not, must be taken or refused by the C
decoder exactly as the Python decoder takes or refuses them.
"""

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vehil.boards import BoardOptions, open_board
from vehil.protocol import frame
from vehil.protocol.schema import SCHEMA

PING = SCHEMA.messages["PING"].type


# the suite's profile's (tests/conftest.py), and the module's link shared by every example
UNTIMED = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture]


@pytest.fixture(scope="module")
def link(built):  # noqa: ANN001, ANN201
    with open_board("native", BoardOptions(timeout_s=0.2)) as link:
        yield link


@settings(max_examples=300, suppress_health_check=UNTIMED)
@given(payload=st.binary(max_size=SCHEMA.max_body - 4))
def test_c_encoder_frames_decode_in_python(link, payload: bytes) -> None:
    assert link.request("PING", payload=payload).fields()["payload"] == payload


@settings(max_examples=300, suppress_health_check=UNTIMED)
@given(
    payload=st.binary(max_size=40),
    edits=st.lists(st.tuples(st.integers(0, 200), st.integers(0, 255)), max_size=3),
)
def test_c_decoder_takes_and_refuses_what_python_does(link, payload, edits) -> None:
    wire = bytearray(frame.encode(PING, 7, payload)[:-1])
    for where, value in edits:  # overwrite or insert bytes, never a delimiter
        if value == 0:
            continue
        if where % 2:
            wire[where % len(wire)] = value
        else:
            wire.insert(where % (len(wire) + 1), value)
    try:
        frame.decode(bytes(wire))
        python_takes = True
    except frame.FrameError:
        python_takes = False
    before = link.stats()
    link.port.write(bytes(wire) + b"\x00")
    if python_takes:
        reply = link.port.read(256)
        assert reply.endswith(b"\x00") and frame.decode(reply[:-1], lambda seq: PING)
    after = link.stats()
    refused = sum(after[k] - before[k] for k in ("crc_errors", "cobs_errors", "oversize"))
    assert refused == (0 if python_takes else 1)
