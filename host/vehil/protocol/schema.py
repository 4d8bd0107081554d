"""The wire protocol's schema (messages.toml) as Python objects.

Every message layout, error code, mode and status bit comes from the one TOML
file the C header is generated from, so the two sides cannot disagree.
"""

from __future__ import annotations

import json
import struct
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vehil.protocol.crc import INIT, crc32c

SCHEMA_PATH = Path(__file__).with_name("messages.toml")

_STRUCT_CODES = {"u8": "B", "u16": "H", "u32": "I", "i32": "i", "f32": "f"}
C_TYPES = {"u8": "uint8_t", "u16": "uint16_t", "u32": "uint32_t", "i32": "int32_t", "f32": "float"}


class SchemaError(ValueError):
    """messages.toml breaks one of its own rules."""


@dataclass(frozen=True)
class Field:
    name: str
    type: str


@dataclass(frozen=True)
class MessageType:
    """One message layout: fixed little-endian fields, optionally a trailing `bytes` field."""

    name: str
    type: int
    doc: str
    fields: tuple[Field, ...]
    reply: str | None = None  # a request's answer besides ERROR

    @property
    def fixed(self) -> tuple[Field, ...]:
        return tuple(f for f in self.fields if f.type != "bytes")

    @property
    def tail(self) -> str | None:
        last = self.fields[-1] if self.fields else None
        return last.name if last is not None and last.type == "bytes" else None

    @property
    def struct(self) -> struct.Struct:
        return struct.Struct("<" + "".join(_STRUCT_CODES[f.type] for f in self.fixed))

    @property
    def fixed_size(self) -> int:
        return self.struct.size

    def pack(self, **values: Any) -> bytes:
        """Body bytes from field values; every field must be given, nothing else."""
        names = {f.name for f in self.fields}
        missing, extra = names - values.keys(), values.keys() - names
        if missing or extra:
            raise TypeError(
                f"{self.name}: missing fields {sorted(missing)}, unknown fields {sorted(extra)}"
            )
        body = self.struct.pack(*(values[f.name] for f in self.fixed))
        if self.tail is not None:
            body += bytes(values[self.tail])
        return body

    def unpack(self, body: bytes) -> dict[str, Any]:
        """Field values from body bytes; raises ValueError on a wrong length."""
        size = self.fixed_size
        if len(body) < size or (self.tail is None and len(body) != size):
            want = f"at least {size}" if self.tail else f"{size}"
            raise ValueError(f"{self.name} body is {len(body)} bytes, expected {want}")
        values = dict(
            zip((f.name for f in self.fixed), self.struct.unpack_from(body), strict=False)
        )
        if self.tail is not None:
            values[self.tail] = bytes(body[size:])
        return values


@dataclass(frozen=True)
class Schema:
    protocol_version: int
    max_body: int
    messages: dict[str, MessageType]
    error: dict[str, int]
    mode: dict[str, int]
    status: dict[str, int]
    reset_cause: dict[str, int]
    reset_what: dict[str, int]
    # CRC-32C of the schema's content (not its comments): INFO carries the board's, so a
    # host and a board built from different schemas of one protocol version refuse to talk.
    hash: int

    def by_type(self, type_code: int) -> MessageType | None:
        for m in self.messages.values():
            if m.type == type_code:
                return m
        return None


def _check(raw: dict[str, Any]) -> None:
    seen: set[int] = set()
    for m in raw["message"]:
        if m["type"] in seen:
            raise SchemaError(f"message {m['name']}: type 0x{m['type']:02X} used twice")
        seen.add(m["type"])
        for i, f in enumerate(m["fields"]):
            if f["type"] == "bytes" and i != len(m["fields"]) - 1:
                raise SchemaError(f"message {m['name']}: bytes field {f['name']} must be last")
            if f["type"] != "bytes" and f["type"] not in _STRUCT_CODES:
                raise SchemaError(f"message {m['name']}: unknown type {f['type']!r}")


def load(path: Path = SCHEMA_PATH) -> Schema:
    raw = tomllib.loads(path.read_text())
    _check(raw)
    messages = {
        m["name"]: MessageType(
            name=m["name"],
            type=m["type"],
            doc=m["doc"],
            fields=tuple(Field(f["name"], f["type"]) for f in m["fields"]),
            reply=m.get("reply"),
        )
        for m in raw["message"]
    }
    return Schema(
        protocol_version=raw["protocol_version"],
        max_body=raw["max_body"],
        messages=messages,
        error=dict(raw["error"]),
        mode=dict(raw["mode"]),
        status=dict(raw["status"]),
        reset_cause=dict(raw["reset_cause"]),
        reset_what=dict(raw["reset_what"]),
        hash=content_hash(raw),
    )


def content_hash(raw: dict[str, Any]) -> int:
    return crc32c(json.dumps(raw, sort_keys=True).encode()) ^ INIT


SCHEMA = load()
