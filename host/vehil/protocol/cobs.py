"""Consistent Overhead Byte Stuffing (the same algorithm as firmware/lib/proto/cobs.c)."""

from __future__ import annotations


class CobsError(ValueError):
    """Bytes that are not a valid COBS block."""


def encode(data: bytes) -> bytes:
    """Encodes data so it holds no 0x00; the frame delimiter is not added."""
    out = bytearray([0])
    code_at, code = 0, 1
    last = len(data) - 1
    for i, byte in enumerate(data):
        if byte:
            out.append(byte)
            code += 1
        # A full block ends without standing for a zero; open the next only if data follows.
        if not byte or (code == 0xFF and i < last):
            out[code_at] = code
            code_at, code = len(out), 1
            out.append(0)
    out[code_at] = code
    return bytes(out)


def decode(block: bytes) -> bytes:
    """Decodes one block (without its delimiter); raises CobsError if malformed."""
    out = bytearray()
    i, n = 0, len(block)
    while i < n:
        code = block[i]
        i += 1
        if code == 0:
            raise CobsError(f"zero byte at offset {i - 1} inside a COBS block")
        end = i + code - 1
        if end > n:
            raise CobsError(f"block at offset {i - 1} claims {code - 1} bytes, {n - i} left")
        chunk = block[i:end]
        if 0 in chunk:
            raise CobsError(f"zero byte at offset {i + chunk.index(0)} inside a COBS block")
        out += chunk
        i = end
        if code != 0xFF and i < n:
            out.append(0)
    return bytes(out)
