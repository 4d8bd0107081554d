"""Frames on the wire (protocol v3): COBS(type u8 | seq u16 | len u8 | body | crc u32) 0x00,
and a decoder that splits a byte stream into frames and resynchronises on the next 0x00.

The CRC-32C covers one byte that is not sent, the type of the request the frame
answers (0 for a request, or a frame the board sends on its own), then type..body:
a reply is accepted only as the answer to the request it was made for. `len` is
the body's length, checked against the bytes received.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from vehil.protocol import cobs
from vehil.protocol.crc import INIT, crc32c
from vehil.protocol.schema import SCHEMA, MessageType

DELIMITER = b"\x00"
HEADER = struct.Struct("<BHB")  # type, seq, len
HEADER_SIZE = HEADER.size
CRC_SIZE = 4
SEQ_MAX = 0xFFFF
RAW_MAX = HEADER_SIZE + SCHEMA.max_body + CRC_SIZE
WIRE_MAX = RAW_MAX + RAW_MAX // 254 + 1 + 1  # COBS overhead plus the delimiter


class FrameError(ValueError):
    """A frame that failed COBS, length or CRC checks."""


@dataclass(frozen=True)
class Frame:
    type: int
    seq: int
    body: bytes
    wire_size: int = field(default=0, compare=False)  # bytes on the wire, delimiter included

    @property
    def message(self) -> MessageType | None:
        return SCHEMA.by_type(self.type)

    @property
    def name(self) -> str:
        m = self.message
        return m.name if m is not None else f"0x{self.type:02X}"

    def fields(self) -> dict[str, Any]:
        """The body decoded by the schema; ValueError if the type is unknown or the body wrong."""
        m = self.message
        if m is None:
            raise ValueError(f"unknown message type 0x{self.type:02X}")
        return m.unpack(self.body)


def _crc(answers: int, covered: bytes) -> int:
    return crc32c(covered, crc32c(bytes([answers]))) ^ INIT


def encode(type_code: int, seq: int, body: bytes = b"", answers: int = 0) -> bytes:
    """A whole wire frame; `answers` is the type of the request a reply answers."""
    if len(body) > SCHEMA.max_body:
        raise ValueError(f"body of {len(body)} bytes exceeds the protocol's {SCHEMA.max_body}")
    raw = HEADER.pack(type_code, seq & SEQ_MAX, len(body)) + body
    return cobs.encode(raw + struct.pack("<I", _crc(answers, raw))) + DELIMITER


def decode(block: bytes, answers: Callable[[int], int] = lambda seq: 0) -> Frame:
    """Decodes the bytes between two delimiters. `answers(seq)` is the type of the request
    a frame with that seq answers (0: none), which its CRC must cover."""
    try:
        raw = cobs.decode(block)
    except cobs.CobsError as exc:
        raise FrameError(f"bad COBS: {exc}") from None
    if len(raw) < HEADER_SIZE + CRC_SIZE:
        raise FrameError(f"frame of {len(raw)} bytes is shorter than header and CRC")
    type_code, seq, length = HEADER.unpack_from(raw)
    covered, (crc,) = raw[:-CRC_SIZE], struct.unpack("<I", raw[-CRC_SIZE:])
    expected = _crc(answers(seq), covered)
    if expected != crc:
        raise FrameError(f"CRC mismatch: frame says 0x{crc:08X}, bytes give 0x{expected:08X}")
    body = bytes(covered[HEADER_SIZE:])
    if length != len(body):
        raise FrameError(f"length field says {length} body bytes, the frame has {len(body)}")
    return Frame(type_code, seq, body, len(block) + 1)


@dataclass
class StreamDecoder:
    """Splits received bytes into frames; counts what it had to drop."""

    buffer: bytearray = field(default_factory=bytearray)
    answers: Callable[[int], int] = lambda seq: 0  # seq -> the request type it answers
    bad_frames: int = 0
    oversize: int = 0
    last_error: str = ""

    def feed(self, data: bytes) -> list[Frame]:
        self.buffer += data
        frames = []
        while (end := self.buffer.find(0)) >= 0:
            block = bytes(self.buffer[:end])
            del self.buffer[: end + 1]
            if not block:
                continue
            try:
                frames.append(decode(block, self.answers))
            except FrameError as exc:
                self.bad_frames += 1
                self.last_error = str(exc)
        if len(self.buffer) > WIRE_MAX:  # no delimiter in sight: garbage, drop it
            self.buffer.clear()
            self.oversize += 1
            self.last_error = f"more than {WIRE_MAX} bytes without a frame delimiter"
        return frames
