"""Frames: CRC, round trips, replies bound to their request, and a stream decoder that
resynchronises after garbage."""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vehil.protocol import frame
from vehil.protocol.crc import INIT, crc32c
from vehil.protocol.schema import SCHEMA


def test_crc_matches_the_crc32c_check_value() -> None:
    assert crc32c(b"123456789") ^ INIT == 0xE3069283


@given(st.integers(0, 255), st.integers(0, 0xFFFF), st.binary(max_size=SCHEMA.max_body))
def test_round_trip(type_code: int, seq: int, body: bytes) -> None:
    wire = frame.encode(type_code, seq, body)
    assert wire.endswith(b"\x00") and wire.count(0) == 1
    assert len(wire) <= frame.WIRE_MAX
    f = frame.decode(wire[:-1])
    assert (f.type, f.seq, f.body, f.wire_size) == (type_code, seq, body, len(wire))


def test_oversize_body_is_refused() -> None:
    with pytest.raises(ValueError, match="exceeds"):
        frame.encode(1, 1, bytes(SCHEMA.max_body + 1))


@given(st.binary(min_size=1, max_size=40), st.integers(0, 1000))
def test_any_single_bit_flip_is_detected(body: bytes, where: int) -> None:
    wire = bytearray(frame.encode(0x05, 7, body)[:-1])
    bit = where % (len(wire) * 8)
    wire[bit // 8] ^= 1 << (bit % 8)
    if 0 in wire:
        return  # the flip made a delimiter: the stream decoder splits there instead
    with pytest.raises(frame.FrameError):
        frame.decode(bytes(wire))


def test_a_reply_passes_only_as_the_answer_to_its_own_request_type() -> None:
    pong = frame.encode(0x82, 300, b"echo", answers=0x02)  # answers a PING
    assert frame.decode(pong[:-1], lambda seq: 0x02).body == b"echo"
    with pytest.raises(frame.FrameError, match="CRC"):
        frame.decode(pong[:-1], lambda seq: 0x05)  # as if it answered a SAMPLE with seq 300


def test_a_length_field_that_disagrees_with_the_body_is_refused() -> None:
    raw = frame.HEADER.pack(0x02, 1, 3) + b"ab"  # says 3 body bytes, has 2
    crc = crc32c(raw, crc32c(b"\x00")) ^ INIT
    wire = frame.cobs.encode(raw + crc.to_bytes(4, "little"))
    with pytest.raises(frame.FrameError, match="length field says 3"):
        frame.decode(wire)


def test_stream_decoder_resyncs_after_garbage_and_counts_it() -> None:
    good1 = frame.encode(0x02, 1, b"abc")
    good2 = frame.encode(0x02, 2, b"def")
    dec = frame.StreamDecoder()
    frames = dec.feed(b"\x13\x37garbage\x00" + good1[:3])
    frames += dec.feed(good1[3:] + b"\x00\x00" + good2)
    assert [(f.seq, f.body) for f in frames] == [(1, b"abc"), (2, b"def")]
    assert dec.bad_frames == 1
    assert "COBS" in dec.last_error or "CRC" in dec.last_error


def test_stream_decoder_drops_an_endless_run_without_delimiter() -> None:
    dec = frame.StreamDecoder()
    assert dec.feed(b"\x01" * (frame.WIRE_MAX + 1)) == []
    assert dec.oversize == 1
    assert dec.feed(frame.encode(0x02, 3, b"x"))[0].seq == 3
