"""The one schema: its rules, its codec, and the generated C header kept in step."""

import pytest

from vehil.protocol import gen_c
from vehil.protocol.schema import SCHEMA


def test_committed_c_header_is_what_the_schema_generates() -> None:
    committed = gen_c.HEADER_PATH.read_text()
    assert committed == gen_c.render(), (
        "firmware/lib/proto/messages.h is out of date: run `python -m vehil.protocol.gen_c`"
    )


def test_requests_and_replies_have_distinct_types() -> None:
    types = [m.type for m in SCHEMA.messages.values()]
    assert len(types) == len(set(types))
    for m in SCHEMA.messages.values():
        assert (m.type & 0x80 != 0) == (
            m.name in {"INFO", "PONG", "ACK", "RESULT", "STATS", "ESTIMATOR", "ERROR"}
        )


def test_pack_and_unpack_round_trip_with_a_trailing_bytes_field() -> None:
    result = SCHEMA.messages["RESULT"]
    body = result.pack(status=3, cycles=123456, outputs=b"\x01\x02")
    assert len(body) == result.fixed_size + 2
    assert result.unpack(body) == {"status": 3, "cycles": 123456, "outputs": b"\x01\x02"}


def test_pack_names_missing_and_unknown_fields() -> None:
    with pytest.raises(TypeError, match=r"missing fields \['cycles'\].*unknown fields \['cycle'\]"):
        SCHEMA.messages["RESULT"].pack(status=0, cycle=1, outputs=b"")


def test_unpack_refuses_a_wrong_length() -> None:
    with pytest.raises(ValueError, match="ACK body is 2 bytes, expected 1"):
        SCHEMA.messages["ACK"].unpack(b"\x01\x02")
