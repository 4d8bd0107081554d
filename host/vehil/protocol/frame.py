"""Frames on the wire: COBS(type | seq | body | crc16-le) 0x00, and a decoder
that splits a byte stream into frames and resynchronises on the next 0x00."""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import Any

from vehil.protocol import cobs
from vehil.protocol.crc import crc16
from vehil.protocol.schema import SCHEMA, MessageType

DELIMITER = b"\x00"
HEADER_SIZE = 2
CRC_SIZE = 2
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


def encode(type_code: int, seq: int, body: bytes = b"") -> bytes:
    if len(body) > SCHEMA.max_body:
        raise ValueError(f"body of {len(body)} bytes exceeds the protocol's {SCHEMA.max_body}")
    raw = bytes([type_code, seq & 0xFF]) + body
    return cobs.encode(raw + struct.pack("<H", crc16(raw))) + DELIMITER


def decode(block: bytes) -> Frame:
    """Decodes the bytes between two delimiters."""
    try:
        raw = cobs.decode(block)
    except cobs.CobsError as exc:
        raise FrameError(f"bad COBS: {exc}") from None
    if len(raw) < HEADER_SIZE + CRC_SIZE:
        raise FrameError(f"frame of {len(raw)} bytes is shorter than header and CRC")
    covered, (crc,) = raw[:-CRC_SIZE], struct.unpack("<H", raw[-CRC_SIZE:])
    if crc16(covered) != crc:
        raise FrameError(f"CRC mismatch: frame says 0x{crc:04X}, bytes give 0x{crc16(covered):04X}")
    return Frame(covered[0], covered[1], bytes(covered[HEADER_SIZE:]), len(block) + 1)


@dataclass
class StreamDecoder:
    """Splits received bytes into frames; counts what it had to drop."""

    buffer: bytearray = field(default_factory=bytearray)
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
                frames.append(decode(block))
            except FrameError as exc:
                self.bad_frames += 1
                self.last_error = str(exc)
        if len(self.buffer) > WIRE_MAX:  # no delimiter in sight: garbage, drop it
            self.buffer.clear()
            self.oversize += 1
            self.last_error = f"more than {WIRE_MAX} bytes without a frame delimiter"
        return frames
