"""The one schema: its rules, its codec, and the generated C header kept in step."""

from pathlib import Path

import pytest
import serial

from vehil.errors import ProtocolMismatch
from vehil.link import Link
from vehil.protocol import frame, gen_c
from vehil.protocol.schema import SCHEMA, SCHEMA_PATH, load


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


def test_the_schema_hash_follows_content_not_comments(tmp_path: Path) -> None:
    def hash_of(text: str) -> int:
        (tmp_path / "messages.toml").write_text(text)
        return load(tmp_path / "messages.toml").hash

    text = SCHEMA_PATH.read_text()
    assert hash_of(text + "\n# a comment\n") == SCHEMA.hash
    assert hash_of(text.replace("max_body = 128", "max_body = 127")) != SCHEMA.hash


def _info_body(schema_hash: int) -> bytes:
    m = SCHEMA.messages["INFO"]
    values = {f.name: 0 for f in m.fields}
    return m.pack(**{**values, "protocol": SCHEMA.protocol_version, "schema_hash": schema_hash})


@pytest.mark.parametrize(
    ("body", "error"),
    [
        (_info_body(SCHEMA.hash ^ 1), "built from another messages.toml of protocol v"),
        (_info_body(SCHEMA.hash)[:3], "built from another messages.toml"),
        (bytes([SCHEMA.protocol_version - 1]) + _info_body(0)[1:], "speaks protocol v"),
    ],
)
def test_a_board_from_another_schema_is_refused_naming_both_hashes(body: bytes, error: str) -> None:
    port = serial.serial_for_url("loop://", timeout=0.05)
    port.write(frame.encode(SCHEMA.messages["INFO"].type, 0, body))
    with pytest.raises(ProtocolMismatch, match=error) as exc:
        Link(port).wait_ready(1.0)
    assert "vehil build" in str(exc.value)


def test_a_board_from_this_schema_is_accepted() -> None:
    port = serial.serial_for_url("loop://", timeout=0.05)
    port.write(frame.encode(SCHEMA.messages["INFO"].type, 0, _info_body(SCHEMA.hash)))
    assert Link(port).wait_ready(1.0)["schema_hash"] == SCHEMA.hash
