"""COBS: round trips, the 254-byte block boundary, and malformed input."""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vehil.protocol import cobs


@given(st.binary(max_size=1000))
def test_round_trip_restores_any_bytes(data: bytes) -> None:
    encoded = cobs.encode(data)
    assert 0 not in encoded
    assert cobs.decode(encoded) == data


@given(st.binary(max_size=1000))
def test_overhead_is_at_most_one_byte_per_254(data: bytes) -> None:
    assert len(cobs.encode(data)) <= len(data) + len(data) // 254 + 1


@pytest.mark.parametrize(
    ("data", "encoded"),
    [
        (b"", b"\x01"),
        (b"\x00", b"\x01\x01"),
        (b"\x00\x00", b"\x01\x01\x01"),
        (b"\x11\x22\x00\x33", b"\x03\x11\x22\x02\x33"),
        (b"\x11\x00\x00\x00", b"\x02\x11\x01\x01\x01"),
        (bytes(range(1, 255)), b"\xff" + bytes(range(1, 255))),
        (bytes(range(1, 256)), b"\xff" + bytes(range(1, 255)) + b"\x02\xff"),
        (bytes(range(0, 255)), b"\x01\xff" + bytes(range(1, 255))),
    ],
)
def test_known_encodings(data: bytes, encoded: bytes) -> None:
    assert cobs.encode(data) == encoded
    assert cobs.decode(encoded) == data


@pytest.mark.parametrize(
    ("block", "problem"),
    [
        (b"\x05\x11\x22", "claims 4 bytes"),
        (b"\x03\x11\x00", "zero byte"),
        (b"\x00", "zero byte"),
    ],
)
def test_malformed_blocks_are_refused(block: bytes, problem: str) -> None:
    with pytest.raises(cobs.CobsError, match=problem):
        cobs.decode(block)
